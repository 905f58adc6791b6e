"""PolyScope program files for the tests: real ones (URCL's integration-test programs, as PolyScope saved them) and
a builder for synthetic trees in the same shape."""
import gzip
from pathlib import Path

# Universal_Robots_Client_Library tests/resources/dockerursim/programs/e-series/*.urp (gunzipped; Apache-2.0), the
# programs URCL's CI loads into URSim 5.x; cb3/*.urp differ only in the header attributes and the UR5's kinematics.
E_SERIES_WAIT_PROGRAM = """\
<URProgram name="wait_program" installation="default" installationRelativePath="default" directory="/ursim/programs" \
createdIn="5.12.4.1101661" lastSavedIn="5.12.4.1101661" robotSerialNumber="20195599999" crcValue="3646307029">
  <kinematics status="NOT_INITIALIZED" validChecksum="false">
    <deltaTheta value="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/>
    <a value="0.0, -0.425, -0.3922, 0.0, 0.0, 0.0"/>
    <d value="0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996"/>
    <alpha value="1.570796327, 0.0, 0.0, 1.570796327, -1.570796327, 0.0"/>
    <jointChecksum value="-1, -1, -1, -1, -1, -1"/>
  </kinematics>
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

E_SERIES_EXTERNAL_CONTROL = """\
<URProgram name="external_control" installation="default" installationRelativePath="default" \
directory="/ursim/programs" createdIn="5.17.2" lastSavedIn="5.19.0" robotSerialNumber="20195599999" \
createdInPolyscopeProgramVersion="2" lastSavedInPolycopeProgramVersion="2" crcValue="2384686873">
  <kinematics status="NOT_INITIALIZED" validChecksum="false">
    <deltaTheta value="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/>
    <a value="0.0, -0.425, -0.3922, 0.0, 0.0, 0.0"/>
    <d value="0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996"/>
    <alpha value="1.570796327, 0.0, 0.0, 1.570796327, -1.570796327, 0.0"/>
    <jointChecksum value="-1, -1, -1, -1, -1, -1"/>
  </kinematics>
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

UR5E_KINEMATICS = """<kinematics status="NOT_INITIALIZED" validChecksum="false">
    <deltaTheta value="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/>
    <a value="0.0, -0.425, -0.3922, 0.0, 0.0, 0.0"/>
    <d value="0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996"/>
    <alpha value="1.570796327, 0.0, 0.0, 1.570796327, -1.570796327, 0.0"/>
    <jointChecksum value="-1, -1, -1, -1, -1, -1"/>
  </kinematics>"""


def program_xml(main: str, name: str = "test_program", run_once: bool = True, top: str = "") -> str:
    """A `<URProgram>` whose MainProgram holds `main` (XML of nodes); `top` adds top-level nodes before it."""
    return (f'<URProgram name="{name}" installation="default" directory="/ursim/programs" createdIn="5.12.4">'
            f"{UR5E_KINEMATICS}<children>{top}"
            f'<MainProgram runOnlyOnce="{str(run_once).lower()}" InitVariablesNode="false">'
            f"<children>{main}</children></MainProgram></children></URProgram>")


def expression(text: str) -> str:
    """An `<expression>` as PolyScope stores typed text: one ExpressionChar per character."""
    chars = "".join(f'<ExpressionChar character="{_xml_attribute(c)}"/>' for c in text)
    return f"<expression>{chars}</expression>"


def _xml_attribute(text: str) -> str:
    return text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;").replace(">", "&gt;")


def write_urp(path: Path, xml: str) -> Path:
    """`xml` gzip-compressed into `path` (a .urp)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(gzip.compress(xml.encode("utf-8"), mtime=0))
    return path
