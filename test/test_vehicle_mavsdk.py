"""MAVSDK 3.17.4 (a real third-party ground station, with its bundled mavsdk_server) flies the
simulated vehicle in both autopilot modes: discovery, health after the boot phase, parameters,
arm, takeoff, offboard position, land, and the simulator never fails on what MAVSDK sends."""
import asyncio
import gc
import socket
import time
import warnings

import pytest

from uav_insar_sim.vehicle.simulator import SimVehicle

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # 3.17.4 warns that the name moves to mavsdk-grpc
    mavsdk = pytest.importorskip("mavsdk", reason="mavsdk (pip install mavsdk==3.17.4) is "
                                 "not installed; it is in the `test` extra")
from mavsdk.action import ActionError  # noqa: E402
from mavsdk.offboard import PositionNedYaw  # noqa: E402

pytestmark = [pytest.mark.timeout(90),
              pytest.mark.filterwarnings("ignore::DeprecationWarning")]
SYSID, MAVSDK_SYSID = 7, 245  # 245: MAVSDK's default own system id
SPEED_PARAM = {"ardupilot": ("WPNAV_SPEED", 100.0), "px4": ("MPC_XY_VEL_MAX", 1.0)}
SYSID_PARAM = {"ardupilot": "SYSID_THISMAV", "px4": "MAV_SYS_ID"}
GCS_PARAM = {"ardupilot": "MAV_GCS_SYSID", "px4": "SIM_GCS_SYSID"}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def first(stream, predicate, timeout: float):
    """The first item of an async MAVSDK stream that satisfies `predicate`."""
    async def scan():
        async for item in stream:
            if predicate(item):
                return item
    return await asyncio.wait_for(scan(), timeout)


async def until(predicate, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        await asyncio.sleep(0.05)
    return predicate()


async def fly(drone, vehicle: SimVehicle, autopilot: str) -> None:
    try:
        await drone.connect(system_address=f"udpout://127.0.0.1:{vehicle.port}")
        await first(drone.core.connection_state(), lambda s: s.is_connected, 10.0)
        if vehicle.boot_remaining_s > 1.0:  # the boot phase: arming is refused
            with pytest.raises(ActionError):
                await drone.action.arm()
        health = await first(drone.telemetry.health(), lambda h: h.is_global_position_ok
                             and h.is_home_position_ok and h.is_armable, 10.0)
        assert health.is_local_position_ok and health.is_gyrometer_calibration_ok
        assert vehicle.booted
        assert await first(drone.telemetry.health_all_ok(), bool, 5.0)
        home = await first(drone.telemetry.home(), lambda p: True, 5.0)
        assert home.latitude_deg == pytest.approx(-35.363261, abs=1e-6)
        assert home.absolute_altitude_m == pytest.approx(584.0, abs=0.01)

        name, scale = SPEED_PARAM[autopilot]
        assert await drone.param.get_param_int(SYSID_PARAM[autopilot]) == SYSID
        assert await drone.param.get_param_int(GCS_PARAM[autopilot]) == MAVSDK_SYSID
        await drone.param.set_param_int(GCS_PARAM[autopilot], MAVSDK_SYSID)
        assert await drone.param.get_param_float(name) == pytest.approx(10.0 * scale)
        await drone.param.set_param_float(name, 8.0 * scale)
        assert vehicle._ap.max_speed == pytest.approx(8.0)

        await drone.action.arm()
        assert vehicle.armed
        await drone.action.set_takeoff_altitude(4.0)
        await drone.action.takeoff()
        assert await until(lambda: vehicle.position_ned[2] < -3.8, 10.0), vehicle.position_ned
        await first(drone.telemetry.in_air(), bool, 5.0)

        await drone.offboard.set_position_ned(PositionNedYaw(5.0, 3.0, -6.0, 0.0))
        await drone.offboard.start()  # the standard order: a setpoint first, then start
        assert vehicle.mode == ("OFFBOARD" if autopilot == "px4" else "GUIDED")
        assert await until(lambda: max(abs(a - b) for a, b in zip(
            vehicle.position_ned, (5.0, 3.0, -6.0), strict=True)) < 0.15, 10.0)
        ned = await first(drone.telemetry.position_velocity_ned(), lambda p: True, 5.0)
        assert ned.position.north_m == pytest.approx(5.0, abs=0.2)

        await drone.action.land()
        assert await until(lambda: not vehicle.armed and vehicle.landed, 15.0)
        assert vehicle.errors == 0
    finally:
        drone._stop_mavsdk_server()


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_mavsdk_flies_the_simulator(autopilot):
    vehicle = SimVehicle(SYSID, "udpin:127.0.0.1:0", autopilot, max_speed=10.0,
                         max_accel=6.0, boot_s=3.5, gcs_sysid=MAVSDK_SYSID)
    vehicle.start()
    drone = mavsdk.System(port=free_port())  # its own gRPC port: runs may overlap
    try:
        asyncio.run(asyncio.wait_for(fly(drone, vehicle, autopilot), 55.0))
    finally:
        drone._stop_mavsdk_server()  # idempotent; also stops it if connect() failed
        vehicle.stop()
        del drone  # System.__del__ (it stops the server again) runs now, not at exit
        gc.collect()
    assert vehicle._thread is None
