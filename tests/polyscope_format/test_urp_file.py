"""The hardened `.urp` reader (polyscope_format.urp_file): hostile and broken files end in one clear
UrpFormatError, quickly and without exhausting memory; XStream references resolve as PolyScope wrote them."""
import gzip
import zlib

import pytest

from polyscope_format import urp_file
from polyscope_format.urp_file import UrpFormatError, parse_urp_bytes, read_installation, read_urp
from urp_samples import E_SERIES_WAIT_PROGRAM, program_xml, write_urp

pytestmark = pytest.mark.timeout(30)  # a hostile file must never hang the reader

BILLION_LAUGHS = ('<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol "lol">'
                  + "".join(f'<!ENTITY lol{n} "{("&lol" + str(n - 1) + ";") * 10 if n > 1 else "&lol;" * 10}">'
                            for n in range(1, 10))
                  + ']><URProgram name="x"><children>&lol9;</children></URProgram>')


def test_a_real_program_reads_with_its_name(tmp_path):
    tree = read_urp(str(write_urp(tmp_path / "wait_program.urp", E_SERIES_WAIT_PROGRAM)))
    assert tree.name == "wait_program"
    assert tree.root.find("children/MainProgram/children/Wait/waitTime").text == "0.01"


def test_a_plain_xml_program_as_polyscope_3_saved_it_reads_too(tmp_path):
    path = tmp_path / "plain.urp"
    path.write_text(E_SERIES_WAIT_PROGRAM, encoding="utf-8")
    assert read_urp(str(path)).root.find("children/MainProgram") is not None


def test_references_resolve_relative_to_the_referring_element():
    xml = program_xml('<Set type="DigitalOutput"><pin referencedName="digital_out[0]"/></Set>'
                      '<Set type="DigitalOutput"><pin referencedName="digital_out[5]"/></Set>'
                      '<Set type="DigitalOutput"><pin reference="../../Set[2]/pin"/></Set>')
    tree = parse_urp_bytes(_gzip(xml.encode()))
    referring = tree.root.findall("children/MainProgram/children/Set")[2].find("pin")
    assert tree.resolve(referring).get("referencedName") == "digital_out[5]"
    assert tree.path_of(referring) == "URProgram/MainProgram/Set[3]/pin"


def _gzip(data: bytes) -> bytes:
    """gzip with a fixed time stamp: parametrize ids built from the bytes must not change between workers."""
    return gzip.compress(data, mtime=0)


@pytest.mark.parametrize("content, message", [
    (b"def wait_program():\n  sleep(1)\nend\n", r"gzip-compressed by PolyScope 5; this file is neither"),
    (b"<Installation/>", r"the XML's root is <Installation>, not <URProgram>"),
    (b'<URProgram><!DOCTYPE x [<!ENTITY a "b">]></URProgram>', r"does not parse|refused"),
    (_gzip(E_SERIES_WAIT_PROGRAM.encode())[:-40], r"truncated"),
    (_gzip(b"this is not XML"), r"its XML does not parse"),
    (_gzip(b"<Installation><IOs/></Installation>"), r"the XML's root is <Installation>, not <URProgram>"),
    (_gzip(b""), r"its XML does not parse"),
    (_gzip(BILLION_LAUGHS.encode()), r"refused: the XML declares a DTD"),
    (_gzip(b'<!DOCTYPE x SYSTEM "file:///etc/passwd"><URProgram/>'), r"refused: the XML declares a DTD"),
    (_gzip(b"<URProgram>" + b"<children>" * 100_000 + b"</children>" * 100_000 + b"</URProgram>"),
     r"nested deeper than 200 levels"),
    (_gzip(b"<URProgram>" + b"<a/>" * 300_000 + b"</URProgram>"), r"more than 250000 elements"),
    (b"\x1f\x8b\x08\x00garbage after the gzip magic", r"corrupt gzip data"),
])
def test_broken_and_hostile_contents_are_refused_with_one_clear_line(content, message):
    with pytest.raises(UrpFormatError, match=message) as refused:
        parse_urp_bytes(content, "prog.urp")
    assert str(refused.value).startswith("prog.urp: ") and "\n" not in str(refused.value)


def test_a_gzip_bomb_is_refused_before_it_is_expanded():
    bomb = _gzip(b"<URProgram>" + b" " * (urp_file.MAX_XML_BYTES + 1024) + b"</URProgram>")
    assert len(bomb) < 100_000  # 32 MB of spaces compress to ~32 KB
    with pytest.raises(UrpFormatError, match=r"decompresses to more than 32 MB of XML"):
        parse_urp_bytes(bomb, "bomb.urp")


def test_a_100_mb_file_is_refused_by_its_size(tmp_path):
    huge = tmp_path / "huge.urp"
    with open(huge, "wb") as sparse:  # a sparse file: 100 MB long, nothing written to disk
        sparse.write(b"\x1f\x8b")
        sparse.truncate(100 * 1000 * 1000)
    with pytest.raises(UrpFormatError, match=r"huge.urp: 100 MB is larger than a PolyScope program can be"):
        read_urp(str(huge))


def test_a_missing_file_and_a_directory_name_the_problem(tmp_path):
    with pytest.raises(UrpFormatError, match=r"cannot be read"):
        read_urp(str(tmp_path / "absent.urp"))


def test_a_second_gzip_member_or_trailing_bytes_do_not_hide_a_truncation():
    stream = zlib.compressobj(wbits=16 + zlib.MAX_WBITS)
    partial = stream.compress(E_SERIES_WAIT_PROGRAM.encode()) + stream.flush(zlib.Z_SYNC_FLUSH)
    with pytest.raises(UrpFormatError, match=r"truncated"):
        parse_urp_bytes(partial, "sync-flushed.urp")


def test_a_broken_or_endless_reference_names_where_it_stands():
    tree = parse_urp_bytes(program_xml('<Set type="DigitalOutput"><pin reference="../../Set[7]/pin"/></Set>'
                                       '<Folder reference="../Folder"/>').encode(), "cell.urp")
    pin, loop = tree.root.find("children/MainProgram/children/Set/pin"), tree.root.find(
        "children/MainProgram/children/Folder")
    with pytest.raises(UrpFormatError, match=r"^cell.urp: broken reference '../../Set\[7\]/pin' at "
                                             r"URProgram/MainProgram/Set/pin$"):
        tree.resolve(pin)
    with pytest.raises(UrpFormatError, match=r"^cell.urp: references nested deeper than 32 at "
                                             r"URProgram/MainProgram/Folder$"):
        tree.resolve(loop)


def test_an_installation_reads_under_the_same_bounds_and_must_be_one(tmp_path):
    installation = tmp_path / "default.installation"
    installation.write_bytes(_gzip(b"<Installation><IOs/></Installation>"))
    assert read_installation(installation).root.tag == "Installation"
    program = write_urp(tmp_path / "cell.urp", E_SERIES_WAIT_PROGRAM)
    with pytest.raises(UrpFormatError, match=r"cell.urp: not a PolyScope installation \(the XML's root is "
                                             r"<URProgram>, not <Installation>\)"):
        read_installation(program)
