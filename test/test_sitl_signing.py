"""MAVLink 2 signing against a real autopilot: one ArduCopter SITL instance (../shared/sitl/),
given our key with SETUP_SIGNING on SERIAL0 (ArduPilot's channel 0, which it always
trusts unsigned, like USB). Then, on its other MAVLink ports: a bridge with the key is linked
and its commands are ACKed; a bridge without a key still hears the (signed) vehicle but its
commands are ignored; a bridge with the wrong key rejects every frame the vehicle sends.
Skipped when the SITL binary is absent."""
from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path

import process_group
import pytest
from side_by_side import flight

from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig
from uav_insar_planner.mavlink.link import Link
from uav_insar_planner.mavlink.signing import signing_timestamp

INSTANCE = 5  # ports 5810 (SERIAL0), 5812, 5813: clear of test_sitl.py's instances 0..2
BASE = 5760 + 10 * INSTANCE
ARDUCOPTER = Path(__file__).resolve().parent.parent.parent / "shared" / "sitl" / "arducopter"
KEY = bytes(range(1, 33))
pytestmark = [
    pytest.mark.timeout(240),  # it may wait for the other SITL flights (side_by_side.py)
    pytest.mark.skipif(not ARDUCOPTER.exists(),
                       reason=f"ArduCopter SITL not found at {ARDUCOPTER}: a user's machine "
                              "does not have it"),
]


def bridge(port: int, key_path: str) -> Bridge:
    return Bridge(BridgeConfig(connections=(f"tcp:127.0.0.1:{port}",), target_sysids=(2,),
                               source_sysid=255, capture_radius_m=0.0, speed_mps=0.0,
                               signing_key_file=key_path))


@pytest.mark.side_by_side("sitl-signing")
def test_arducopter_obeys_only_the_signed_bridge(side_by_side):
    side_by_side.result("sitl-signing")


@flight("sitl-signing", "sitl")
def sign_and_command(tmp_path: Path, domain: int) -> None:
    """The checks of the module doc, side by side with the suite's other SITL flights
    (test/side_by_side.py; no ROS here, `domain` is unused)."""
    (tmp_path / "right").write_bytes(KEY)
    (tmp_path / "wrong").write_bytes(bytes(range(50, 82)))
    for name in ("right", "wrong"):
        os.chmod(tmp_path / name, 0o600)
    sitl = subprocess.Popen(
        [str(ARDUCOPTER), "--model", "+", "--speedup", "1", f"-I{INSTANCE}", "--sysid", "2",
         "--defaults", str(ARDUCOPTER.parent / "copter.parm"),
         "--home", "-35.363261,149.165230,584,353"], cwd=tmp_path,
        stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, start_new_session=True)
    links: list = []
    try:
        time.sleep(1.0)
        usb = Link(f"tcp:127.0.0.1:{BASE}", 255, 190)  # channel 0: unsigned is trusted here
        links.append(usb)
        deadline = time.monotonic() + 20.0
        while not any(m.get_type() == "HEARTBEAT" for m in usb.poll()):
            assert time.monotonic() < deadline, "no heartbeat from SITL"
            time.sleep(0.05)
        usb.send(usb.mav.setup_signing_encode(2, 1, list(KEY), signing_timestamp()))
        time.sleep(1.0)
        signed = bridge(BASE + 2, str(tmp_path / "right"))
        unsigned = bridge(BASE + 3, "")
        links += [signed, unsigned]
        for b in (signed, unsigned):
            b.start()
        deadline = time.monotonic() + 15.0
        while time.monotonic() < deadline and "ACCEPTED" not in signed.status()[0].last_ack:
            usb.poll()  # keep SERIAL0 drained
            time.sleep(0.1)
        time.sleep(1.0)  # time enough for an ACK to the unsigned bridge too, if one came
        s, u = signed.status()[0], unsigned.status()[0]
        assert s.link == "linked" and s.last_ack == "SET_MESSAGE_INTERVAL: ACCEPTED", s
        assert signed.link_stats()[f"tcp:127.0.0.1:{BASE + 2}"].bad_signature == 0
        assert u.link == "linked" and u.last_ack == "", u  # it hears, but is not obeyed
        unsigned.stop()
        wrong = bridge(BASE + 3, str(tmp_path / "wrong"))
        links.append(wrong)
        wrong.start()
        time.sleep(3.0)
        assert wrong.status()[0].link == "waiting"
        assert wrong.link_stats()[f"tcp:127.0.0.1:{BASE + 3}"].bad_signature >= 3
    finally:
        for link in links:
            (link.stop if isinstance(link, Bridge) else link.close)()
        process_group.kill_group(sitl)
