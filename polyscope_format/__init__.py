"""The PolyScope program file format, read and written; shared by ur3dq (import, export) and sim_ursim (play).

- `urp_file`: read a `.urp` or `.installation` safely (gzip or plain XML, bounded in size, element count and depth,
  no DTDs or entities) -> `ProgramTree`, whose XStream references (`reference="../../Set/pin"`) it resolves;
- `installation`: the names a program's installation gave to I/O pins;
- `nodes`: the node vocabulary both sides read the same way: I/O pin names and their URScript functions, the
  pendant's expression symbols, If/ElseIf/Else chains, a node's children and fields;
- `urp_xml`: write a program tree as PolyScope writes it (XStream's layout, Java's doubles, gzip with no time
  stamp: the same tree always gives the same bytes);
- `script_lines`: URScript lines indented as PolyScope indents the script it generates.

This package imports neither ur3dq nor sim_ursim. What is wrong with a file ends in `UrpFormatError` (one line naming
the file and the problem); ur3dq turns it into its `UrpFileError` (exit code 3), sim_ursim into its load error.

>>> from polyscope_format.urp_file import parse_urp_bytes
>>> parse_urp_bytes(b'<URProgram name="p"><children><MainProgram/></children></URProgram>', "p.urp").name
'p'
"""
