"""PolyScope's side of the controller: `.urp` program files read, translated to URScript and played.

- urp_file.py     the hardened reader: gzip XML of bounded size and depth, no DTD or entities (defusedxml),
                  XStream references (`reference="../../Set/pin"`) resolved
- installation.py the program's installation: the names it gave to I/O pins
- expressions.py  expression nodes and I/O pin names -> URScript text
- translation.py  the program tree -> one URScript `def <name>():` program, nodes in order, as PolyScope writes it
- moves.py        Move containers and their Fixed / Relative / Variable waypoints
- external_control.py  the External Control URCap node: its program fetched from the remote PC (`request_program`)
- program_tab.py  the pendant's program tab behind dashboard load/play/stop: the loaded program and its script
"""
