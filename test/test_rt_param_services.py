"""The rcl_interfaces parameter services of our runtime: wire types byte-identical to rosbags,
listing rules, and the real PlannerNode driven through them by a client over Cyclone DDS (what
`ros2 param list/get/describe/set` does)."""
from __future__ import annotations

import math

import pytest
from conftest import spin_until
from test_rt_messages import to_rosbags

from uav_insar_planner import rt
from uav_insar_planner.nodes.planner import LATCHED, PlannerNode
from uav_insar_planner.rt.messages import TYPESTORE, get_message, msg_type, type_hash
from uav_insar_planner.rt.parameter_service import list_parameters
from uav_insar_planner.rt.service import unwrap, wire_type, wrap

Parameter = rt.parameter.Parameter
PType = Parameter.Type
_SRV = "rcl_interfaces/srv/"


def _param(name: str, value) -> object:
    return Parameter(name, value=value).to_parameter_msg()


def _samples():
    m = get_message
    desc = m("rcl_interfaces/msg/ParameterDescriptor")(
        name="h_amb_min_m", type=3, description="h_amb^min [m]", additional_constraints="> 0",
        read_only=True, dynamic_typing=False,
        floating_point_range=[m("rcl_interfaces/msg/FloatingPointRange")(
            from_value=0.0, to_value=math.inf, step=0.0)])
    int_desc = m("rcl_interfaces/msg/ParameterDescriptor")(
        name="num_slots", type=2, integer_range=[m("rcl_interfaces/msg/IntegerRange")(
            from_value=1, to_value=100000, step=1)])
    params = [_param("scheme", "proposed"), _param("num_slots", 80), _param("flag", True),
              _param("g", [70.0, 149.37]), _param("ids", [1, 2]), _param("tags", ["a", "b"]),
              _param("bits", [True, False]), _param("raw", b"\x00\xff\x07"),
              Parameter("unset").to_parameter_msg()]
    result = m("rcl_interfaces/msg/SetParametersResult")
    srv = msg_type
    return [
        ("DescribeParameters_Request", srv(_SRV + "DescribeParameters").Request(
            names=["h_amb_min_m", "num_slots"])),
        ("DescribeParameters_Response", srv(_SRV + "DescribeParameters").Response(
            descriptors=[desc, int_desc])),
        ("GetParameters_Request", srv(_SRV + "GetParameters").Request(names=["scheme"])),
        ("GetParameters_Response", srv(_SRV + "GetParameters").Response(
            values=[p.value for p in params])),
        ("GetParameterTypes_Request", srv(_SRV + "GetParameterTypes").Request(names=["a", "b"])),
        ("GetParameterTypes_Response", srv(_SRV + "GetParameterTypes").Response(
            types=[4, 3, 0])),
        ("ListParameters_Request", srv(_SRV + "ListParameters").Request(
            prefixes=["mavlink"], depth=2)),
        ("ListParameters_Response", srv(_SRV + "ListParameters").Response(
            result=m("rcl_interfaces/msg/ListParametersResult")(
                names=["scheme", "mavlink.port"], prefixes=["mavlink"]))),
        ("SetParameters_Request", srv(_SRV + "SetParameters").Request(parameters=params)),
        ("SetParameters_Response", srv(_SRV + "SetParameters").Response(
            results=[result(successful=True), result(successful=False, reason="out of range")])),
        ("SetParametersAtomically_Request", srv(_SRV + "SetParametersAtomically").Request(
            parameters=params[:3])),
        ("SetParametersAtomically_Response", srv(_SRV + "SetParametersAtomically").Response(
            result=result(successful=False, reason="z_min_m: -5.0 is outside [0, inf]"))),
    ]


@pytest.mark.parametrize(("name", "msg"), _samples(), ids=[n for n, _ in _samples()])
def test_service_types_equal_rosbags_and_round_trip(name, msg):
    ros_type = _SRV + name
    assert type(msg).__idl_typename__ == f"rcl_interfaces::srv::dds_::{name}_"
    ours = msg.serialize()
    assert ours == bytes(TYPESTORE.serialize_cdr(to_rosbags(msg, ros_type), ros_type))
    assert type(msg).deserialize(ours).serialize() == ours
    # With the rmw_cyclonedds request header in front, as it travels.
    back = unwrap(wire_type(type(msg)).deserialize(wrap(msg, 5, 9).serialize()), type(msg))
    assert back.serialize() == ours
    assert type_hash(ros_type).startswith("RIHS01_")


def test_parameter_msg_conversion_round_trips():
    for value in ("proposed", 80, 1.2, True, [70.0, 1.5], [1, 2], ["a"], [True], b"\x00\xff"):
        p = Parameter("x", value=value)
        wire = type(p.to_parameter_msg()).deserialize(p.to_parameter_msg().serialize())
        assert Parameter.from_parameter_msg(wire) == p
    assert Parameter.from_parameter_msg(Parameter("u").to_parameter_msg()).type_ == PType.NOT_SET
    assert msg_type(_SRV + "ListParameters").Request.DEPTH_RECURSIVE == 0


def test_list_parameters_prefix_and_depth_rules():
    names = ["a", "b.c", "b.d.e", "bx.f"]

    def listed(prefixes, depth):
        r = list_parameters(names, prefixes, depth)
        return list(r.names), list(r.prefixes)

    assert listed([], 0) == (names, ["b", "b.d", "bx"])
    assert listed([], 1) == (["a"], [])
    assert listed([], 2) == (["a", "b.c", "bx.f"], ["b", "bx"])
    assert listed(["b"], 0) == (["b.c", "b.d.e"], ["b", "b.d"])  # not "bx.f"
    assert listed(["b"], 1) == (["b.c"], ["b"])
    assert listed(["a", "b.d"], 0) == (["a", "b.d.e"], ["b.d"])


class PlannerUnderTest:
    """The real PlannerNode, a client node with one client per parameter service and a
    /formation watcher, all on one executor in the test's context."""

    def __init__(self, ctx) -> None:
        self.planner = PlannerNode(context=ctx, parameter_overrides=[
            Parameter("num_slots", value=6)])
        assert not self.planner.problems
        self.cli_node = rt.Node("param_client", context=ctx)
        self.formations: list = []
        self.cli_node.create_subscription(msg_type("geometry_msgs/msg/PoseArray"), "/formation",
                                          self.formations.append, LATCHED)
        self.events: list = []
        self.cli_node.create_subscription(msg_type("rcl_interfaces/msg/ParameterEvent"),
                                          "/parameter_events", self.events.append, 1000)
        self.clients = {name: self.cli_node.create_client(msg_type(_SRV + srv), f"/planner/{name}")
                        for name, srv in (("list_parameters", "ListParameters"),
                                          ("get_parameters", "GetParameters"),
                                          ("get_parameter_types", "GetParameterTypes"),
                                          ("describe_parameters", "DescribeParameters"),
                                          ("set_parameters", "SetParameters"),
                                          ("set_parameters_atomically",
                                           "SetParametersAtomically"))}
        self.executor = rt.SingleThreadedExecutor(context=ctx)
        self.executor.add_node(self.planner)
        self.executor.add_node(self.cli_node)

    def spin_until(self, done, timeout: float) -> bool:
        return spin_until(self.executor, done, timeout)

    def call(self, service: str, **fields):
        client = self.clients[service]
        assert client.wait_for_service(timeout_sec=5.0), service
        future = client.call_async(client.srv_type.Request(**fields))
        assert self.spin_until(future.done, 5.0), f"no reply from {service}"
        return future.result()

    def get(self, *names: str) -> list:
        return list(self.call("get_parameters", names=list(names)).values)

    def close(self) -> None:
        self.planner.stop()
        self.planner.destroy_node()
        self.cli_node.destroy_node()


@pytest.fixture
def planner(rt_context):
    under_test = PlannerUnderTest(rt_context)
    yield under_test
    under_test.close()


def test_list_get_and_describe_the_planners_parameters(planner):
    listed = planner.call("list_parameters", prefixes=[], depth=0).result
    assert {"scheme", "h_amb_min_m", "num_slots", "use_sim_time"} <= set(listed.names)
    assert len(listed.names) == len(set(listed.names))

    scheme, h_amb, slots = planner.get("scheme", "h_amb_min_m", "num_slots")
    assert (scheme.type, scheme.string_value) == (PType.STRING, "proposed")
    assert (h_amb.type, h_amb.double_value) == (PType.DOUBLE, 1.2)
    assert (slots.type, slots.integer_value) == (PType.INTEGER, 6)  # the override
    assert planner.get("scheme", "no_such_parameter") == []  # rclpy: all or nothing

    types = planner.call("get_parameter_types", names=["scheme", "h_amb_min_m"]).types
    assert list(types) == [PType.STRING, PType.DOUBLE]

    (desc,) = planner.call("describe_parameters", names=["h_amb_min_m"]).descriptors
    assert desc.name == "h_amb_min_m" and desc.type == PType.DOUBLE
    assert desc.description.startswith("h_amb^min, minimum height of ambiguity")
    (rng,) = desc.floating_point_range
    assert (rng.from_value, rng.to_value) == (0.0, math.inf)
    assert planner.call("describe_parameters", names=["nope"]).descriptors == []


def test_set_replans_or_refuses_and_atomic_set_is_all_or_nothing(planner):
    assert planner.spin_until(lambda: planner.formations, 20.0), "no first /formation"
    seen = len(planner.formations)

    (ok,) = planner.call("set_parameters", parameters=[_param("h_amb_min_m", 1.1)]).results
    assert ok.successful, ok.reason
    assert planner.get("h_amb_min_m")[0].double_value == 1.1
    assert planner.spin_until(lambda: len(planner.formations) > seen, 20.0), "no replan"
    assert planner.spin_until(lambda: any(
        e.node == "/planner" and [(p.name, p.value.double_value) for p in e.changed_parameters]
        == [("h_amb_min_m", 1.1)] for e in planner.events), 5.0), "no /parameter_events"

    bad, wrong_type, undeclared = planner.call("set_parameters", parameters=[
        _param("h_amb_min_m", -1.0), _param("h_amb_min_m", 2), _param("nope", 1)]).results
    assert not bad.successful and "h_amb_min_m" in bad.reason and "range" in bad.reason
    assert not wrong_type.successful and "type" in wrong_type.reason
    assert not undeclared.successful and "nope" in undeclared.reason
    assert planner.get("h_amb_min_m")[0].double_value == 1.1

    result = planner.call("set_parameters_atomically", parameters=[
        _param("h_amb_min_m", 1.3), _param("z_min_m", -5.0)]).result
    assert not result.successful and "z_min_m" in result.reason
    h_amb, z_min = planner.get("h_amb_min_m", "z_min_m")
    assert (h_amb.double_value, z_min.double_value) == (1.1, 1.0)
    planner.spin_until(lambda: False, 0.2)
    changes = [p.name for e in planner.events if e.node == "/planner" for p in e.changed_parameters]
    assert changes == ["h_amb_min_m"]  # refused sets announce nothing
