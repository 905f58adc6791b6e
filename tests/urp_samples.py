"""PolyScope program files for the tests of polyscope_format, ur3dq's import and sim_ursim's playback: real ones
(URCL's integration-test programs, as PolyScope saved them) and builders of synthetic trees in the same shape (the
nodes as docs/polyscope.md lists them)."""
import gzip
from pathlib import Path

from polyscope_format.urp_file import ProgramTree, parse_urp_bytes

# Universal_Robots_Client_Library tests/resources/dockerursim/programs/{e-series,cb3}/*.urp (gunzipped; Apache-2.0),
# the programs URCL's CI loads into URSim; CB3 differs in the header and the UR5's kinematics.
UR5E_KINEMATICS = """<kinematics status="NOT_INITIALIZED" validChecksum="false">
    <deltaTheta value="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/>
    <a value="0.0, -0.425, -0.3922, 0.0, 0.0, 0.0"/>
    <d value="0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996"/>
    <alpha value="1.570796327, 0.0, 0.0, 1.570796327, -1.570796327, 0.0"/>
    <jointChecksum value="-1, -1, -1, -1, -1, -1"/>
  </kinematics>"""
UR5_KINEMATICS = UR5E_KINEMATICS.replace("-0.3922,", "-0.39225,").replace(
    "0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996", "0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823")
E_SERIES_WAIT_PROGRAM = f"""\
<URProgram name="wait_program" installation="default" installationRelativePath="default" directory="/ursim/programs" \
createdIn="5.12.4.1101661" lastSavedIn="5.12.4.1101661" robotSerialNumber="20195599999" crcValue="3646307029">
  {UR5E_KINEMATICS}
  <children>
    <MainProgram runOnlyOnce="false" InitVariablesNode="false">
      <children>
        <Wait type="Sleep">
          <waitTime>0.01</waitTime>
        </Wait>
      </children>
    </MainProgram>
  </children>
</URProgram>"""
CB3_WAIT_PROGRAM = E_SERIES_WAIT_PROGRAM.replace(UR5E_KINEMATICS, UR5_KINEMATICS).replace(
    'createdIn="5.12.4.1101661" lastSavedIn="5.12.4.1101661" robotSerialNumber="20195599999" crcValue="3646307029"',
    'createdIn="3.15.8.106339" lastSavedIn="3.12.1.90940" robotSerialNumber="2018359999" crcValue="2588156642"')
E_SERIES_EXTERNAL_CONTROL = f"""\
<URProgram name="external_control" installation="default" installationRelativePath="default" \
directory="/ursim/programs" createdIn="5.17.2" lastSavedIn="5.19.0" robotSerialNumber="20195599999" \
createdInPolyscopeProgramVersion="2" lastSavedInPolycopeProgramVersion="2" crcValue="2384686873">
  {UR5E_KINEMATICS}
  <children>
    <InitVariablesNode/>
    <MainProgram runOnlyOnce="true" InitVariablesNode="true">
      <children>
        <Contributed strategyClass="com.fzi.externalcontrol.ExternalControlNode" \
strategyProgramNodeType="External Control" strategyURCapDeveloper="FZI Research Center for Information Technology" \
strategyURCapName="External Control">
          <dataModel/>
        </Contributed>
      </children>
    </MainProgram>
  </children>
</URProgram>"""
HOME = (0.3, -1.3, 1.4, -1.7, -1.57, 0.4)


def program_xml(main: str, name: str = "cell", top: str = "", kinematics: str = UR5E_KINEMATICS,
                run_once: bool = True) -> str:
    """A `<URProgram>` whose MainProgram holds `main` (XML of nodes); `top` adds top-level nodes before it."""
    return (f'<URProgram name="{name}" installation="default" directory="/programs" createdIn="5.12.4">'
            f"{kinematics}<children>{top}"
            f'<MainProgram runOnlyOnce="{str(run_once).lower()}" InitVariablesNode="false">'
            f"<children>{main}</children></MainProgram></children></URProgram>")


def tree(main: str, **kwargs) -> ProgramTree:
    """The parsed tree of `program_xml(main, ...)` (gzip, as PolyScope 5 saves it)."""
    return parse_urp_bytes(gzip.compress(program_xml(main, **kwargs).encode(), mtime=0), "cell.urp")


def write_urp(path: Path, xml: str) -> Path:
    """`xml` gzip-compressed into `path` (a .urp)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(gzip.compress(xml.encode("utf-8"), mtime=0))
    return path


def expression(text: str) -> str:
    """An `<expression>` as PolyScope stores typed text: one ExpressionChar per character."""
    chars = "".join(f'<ExpressionChar character="{attribute(c)}"/>' for c in text)
    return f"<expression>{chars}</expression>"


def attribute(text: str) -> str:
    """`text` escaped for an XML attribute value."""
    return text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;").replace(">", "&gt;")


def position(q=HOME, tcp=(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), tag="position", kinematics=""):
    """A 5.x recorded position: joint angles, TCP offset (and the waypoint's own kinematics, if given)."""
    return (f'<{tag}><JointAngles angles="{", ".join(map(repr, q))}"/>'
            f'<TCPOffset pose="{", ".join(map(repr, tcp))}"/>{kinematics}</{tag}>')


def waypoint(name, q=HOME, tcp=(0.0,) * 6, parameters="", kinematics=""):
    """A fixed waypoint."""
    return (f'<Waypoint type="Fixed" name="{name}" kinematicsFlags="4"><motionParameters {parameters}/>'
            f'{position(q, tcp, kinematics=kinematics)}<BaseToFeature pose="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/>'
            "</Waypoint>")


def move(kind, *nodes, speed="1.0", acceleration="1.2", extra=""):
    """A Move container holding `nodes`."""
    return (f'<Move motionType="{kind}" speed="{speed}" acceleration="{acceleration}" useActiveTCP="false" {extra}>'
            f'<feature class="GeomFeatureReference" referencedName="Joint_0_name"/>'
            f"<children>{''.join(nodes)}</children></Move>")


def set_digital(pin, on=True):
    """A Set node switching the digital output `pin` (a PolyScope pin name or an installation's name for it)."""
    return f'<Set type="DigitalOutput"><pin referencedName="{pin}"/><digitalValue>{int(on)}</digitalValue></Set>'


def folder(name, *nodes):
    """A Folder holding `nodes`."""
    return f'<Folder name="{attribute(name)}"><children>{"".join(nodes)}</children></Folder>'
