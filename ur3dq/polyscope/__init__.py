"""PolyScope programs (`.urp`) in and out of ur3dq: read one into a cell program, write a cell program as one.

- `urp_file`: read a `.urp` (and its installation's pin names) with ur3dq's errors; the reading itself is the
  polyscope_format package's (gzip or plain XML, bounded, no DTDs or entities) -> `ProgramTree`;
- `nodes`: the tree as the pendant shows it (labels, paths such as `Robot Program/Folder 2/If digital_in[0]`,
  expressions, I/O pins), on polyscope_format's node vocabulary;
- `urp_import`: the tree -> steps (`import_program`), nodes without a step refused by path or kept as URScript
  (`kept_script`); `kinematics`: the arm and calibration a program was saved with;
- `urp_export`: a planned program -> a `.urp` (`export_bytes`), written in PolyScope's XML layout and numbers
  (polyscope_format.urp_xml);
  `annotations`: the `ur3dq: {...}` comments that carry what PolyScope cannot.

ur3dq never imports sim_ursim here: the simulator reads `.urp` files with the same polyscope_format package and
plays them with its own translation.
docs/polyscope.md describes the format and what maps to what.
"""
