"""PolyScope's side of the controller: `.urp` program files read, translated to URScript and played.

The file format itself (the hardened reader, the installation's pin names, the node vocabulary, URScript lines) is
the polyscope_format package, which ur3dq reads programs with too; sim_ursim never imports ur3dq.

- errors.py       UrpError: a program the simulator cannot run (its base, polyscope_format's UrpFormatError: a
                  file that is not a readable program)
- expressions.py  expression nodes and I/O pin names -> URScript text
- translation.py  the program tree -> one URScript `def <name>():` program, nodes in order, as PolyScope writes it
- moves.py        Move containers and their Fixed / Relative / Variable waypoints
- external_control.py  the External Control URCap node: its program fetched from the remote PC (`request_program`)
- program_tab.py  the pendant's program tab behind dashboard load/play/stop: the loaded program and its script
"""
