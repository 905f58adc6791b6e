"""Cell programs: ordered steps (waypoints, relative waypoints, I/O and wait actions), their resolution and
planning on a model, and the one URScript program that runs them (see docs/store-schema.md for the stored form)."""
