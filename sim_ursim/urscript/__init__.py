"""URScript on the simulated controller.

urscript.lark  grammar (lark, LALR)            parser.py    source -> syntax tree (nodes.py), syntax errors
interpreter.py compile (names resolved) + run  builtins/    built-in functions by family, one registry
values.py      URScript values (Pose, to_str)  runtime.py   ProgramRunner: submit / stop / pause / resume
operators.py   binary operators on values (pure)
"""
