"""Bounds on the weighted cost of ik's choice at singular points, shared by the ik tests.

ik_all keeps one of two solutions within DUPLICATE_TOLERANCE (rad, every joint) of each other; ik searches the
equations directly and may return the other copy. Two consequences for a brute force over ik_all's solutions:
the costs Σ wᵢ·(qᵢ − refᵢ)² differ at first order in the tolerance, and near a limit the dropped copy may have an
in-limit ±2π variant that the kept one lacks (e.g. a stretched elbow at θ3 = ±1e-8, the variant 2π − 1e-8 inside,
2π + 1e-8 outside). ik's cost must then lie between the brute force with the limits widened by the tolerance and
the strict brute force.
"""
import math

import numpy as np

from ur3dq.kinematics import ur_ik


def merge_slack(best: float, weights) -> float:
    """First-order cost difference between two copies of one solution: 2·√(Σw·best)·tol·√6 (+1e-12)."""
    return 2.0 * math.sqrt(float(np.sum(weights)) * best) * ur_ik.DUPLICATE_TOLERANCE * math.sqrt(6.0) + 1e-12


def _least_cost_widened(model, solution, reference, weights) -> float:
    """Least cost over the ±2π variants of ``solution`` with every limit widened by DUPLICATE_TOLERANCE (separable
    per joint, so the minimum over the product is the sum of per-joint minima; inf when a joint has none)."""
    total = 0.0
    for x, r, w, low, high in zip(solution, reference, weights, model.joint_lower, model.joint_upper):
        shifts = x + 2.0 * math.pi * np.arange(-4, 5)
        inside = shifts[(shifts >= low - ur_ik.DUPLICATE_TOLERANCE) & (shifts <= high + ur_ik.DUPLICATE_TOLERANCE)]
        if not len(inside):
            return math.inf
        total += w * float(np.min((inside - r) ** 2))
    return total


def assert_least_cost(cost: float, model, pose, reference, weights) -> None:
    """``cost`` is the least over every in-limit variant of every ik_all solution, up to the merge effects above."""
    solutions = ur_ik.ik_all(model, pose, q_ref=reference)
    strict = math.inf
    for solution in solutions:
        variants = ur_ik.joint_variants(model, solution)
        if len(variants):
            strict = min(strict, float(np.min(np.sum(weights * (variants - reference) ** 2, axis=1))))
    widened = min(_least_cost_widened(model, s, reference, weights) for s in solutions)
    assert widened - merge_slack(widened, weights) <= cost <= strict * (1 + 1e-9) + merge_slack(strict, weights), \
        (cost, widened, strict)
