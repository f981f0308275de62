"""The environment a ROS 2 process (rmw_fastrtps_cpp, Fast DDS 2.14, Jazzy) needs in a NetLab
namespace, from what test_netlab.py measures:

- Shared memory: Fast DDS offers its SHM locators only to participants with the same host id,
  md5(hostname + IPv4 addresses); namespaces with different addresses get different ids, so
  even with the default transports (SHM + UDPv4) a cut port stops the traffic (measured).
  FASTDDS_BUILTIN_TRANSPORTS=UDPv4 is set anyway, so no future heuristic (or a namespace
  whose process started before its address existed) can route around the switch.
- "subnet": ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET, SPDP multicast over the switch (the lab's
  route 224.0.0.0/4 dev eth0 carries it).
- "static": ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and ROS_STATIC_PEERS: no multicast frame
  at all, unicast discovery of the peers only; with no peers nothing across the lab is found.
  (OFF is not it: with OFF, Jazzy ignores ROS_STATIC_PEERS and sends nothing.)
- ROS_DOMAIN_ID still separates domains (it sets the ports); it is taken from `base`.
"""
from __future__ import annotations

import ipaddress
import os
from collections.abc import Mapping, Sequence

DISCOVERY = {"subnet": "SUBNET", "static": "LOCALHOST"}


def dds_env(discovery: str = "subnet", peers: Sequence[str] = (),
            base: Mapping[str, str] | None = None) -> dict[str, str]:
    """`base` (default os.environ) with the DDS settings for `discovery` ("subnet" or
    "static") and `peers` (IPv4 addresses, e.g. NetLab.address of the other namespaces) as
    ROS_STATIC_PEERS; ValueError (one line) for anything else."""
    if discovery not in DISCOVERY:
        raise ValueError(f"discovery={discovery!r} not allowed: one of {', '.join(DISCOVERY)}")
    for peer in peers:
        try:
            ipaddress.IPv4Address(peer)
        except ValueError:
            raise ValueError(f"peer {peer!r} not allowed: an IPv4 address") from None
    env = dict(os.environ if base is None else base)
    env.update(RMW_IMPLEMENTATION="rmw_fastrtps_cpp", FASTDDS_BUILTIN_TRANSPORTS="UDPv4",
               ROS_AUTOMATIC_DISCOVERY_RANGE=DISCOVERY[discovery])
    env.pop("ROS_LOCALHOST_ONLY", None)  # deprecated in Jazzy; it would override the range
    if peers:
        env["ROS_STATIC_PEERS"] = ";".join(peers)
    else:
        env.pop("ROS_STATIC_PEERS", None)
    return env
