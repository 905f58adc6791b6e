"""PolyScope programs (`.urp`) in and out of ur3dq: read one into a cell program, write a cell program as one.

- `urp_file`: read a `.urp` safely (gzip or plain XML, bounded, no DTDs or entities) -> `ProgramTree`;
- `nodes`: the tree as the pendant shows it (labels, paths such as `Robot Program/Folder 2/If digital_in[0]`,
  expressions, I/O pins); `installation`: pin names from the program's installation;
- `urp_import`: the tree -> steps (`import_program`), nodes without a step refused by path or kept as URScript
  (`kept_script`); `kinematics`: the arm and calibration a program was saved with;
- `urp_export`: a planned program -> a `.urp` (`export_bytes`), `urp_xml`: PolyScope's XML layout and numbers;
  `annotations`: the `ur3dq: {...}` comments that carry what PolyScope cannot.

ur3dq never imports sim_ursim here: the simulator reads and plays `.urp` files with its own reader.
docs/polyscope.md describes the format and what maps to what.
"""
