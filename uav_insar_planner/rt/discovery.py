"""Which DDS domain and which Cyclone configuration a context uses.

- `ROS_DOMAIN_ID` (default 0) picks the domain, unless `init(domain_id=...)` is given.
- A user's own `CYCLONEDDS_URI` wins: we then pass no configuration and Cyclone reads it.
- Otherwise `ROS_AUTOMATIC_DISCOVERY_RANGE` decides, as in Jazzy:
  LOCALHOST -> loopback only, no multicast, unicast discovery to 127.0.0.1;
  OFF -> loopback only and no peers (only this process);
  SUBNET or unset or SYSTEM_DEFAULT -> Cyclone's default interface and multicast, plus
  unicast discovery to 127.0.0.1, so processes on this host find each other even where
  multicast is unavailable.
  `ROS_STATIC_PEERS` (semicolon-separated addresses) are added as unicast peers.
"""
from __future__ import annotations

import os
import threading

from cyclonedds.domain import Domain

_RANGES = ("SUBNET", "LOCALHOST", "OFF", "SYSTEM_DEFAULT", "")
_LOCK = threading.Lock()
_DOMAINS: dict[int, Domain] = {}


def domain_id_from_env() -> int:
    """ROS_DOMAIN_ID as an int (0 when unset); ValueError when not an integer 0..232."""
    raw = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not raw:
        return 0
    try:
        value = int(raw)
    except ValueError:
        raise ValueError(f"ROS_DOMAIN_ID must be an integer, got {raw!r}") from None
    if not 0 <= value <= 232:
        raise ValueError(f"ROS_DOMAIN_ID must be in 0..232, got {value}")
    return value


def cyclone_config(env: dict[str, str] | None = None) -> str | None:
    """The Cyclone XML for this environment, or None when CYCLONEDDS_URI is set."""
    env = os.environ if env is None else env
    if env.get("CYCLONEDDS_URI", "").strip():
        return None
    rng = env.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper()
    if rng not in _RANGES:
        raise ValueError(f"ROS_AUTOMATIC_DISCOVERY_RANGE must be one of SUBNET, LOCALHOST, "
                         f"OFF, SYSTEM_DEFAULT; got {rng!r}")
    peers = [p.strip() for p in env.get("ROS_STATIC_PEERS", "").split(";") if p.strip()]
    general = ""
    if rng in ("LOCALHOST", "OFF"):
        general = ("<General><Interfaces><NetworkInterface address=\"127.0.0.1\"/>"
                   "</Interfaces><AllowMulticast>false</AllowMulticast></General>")
    if rng != "OFF":
        peers.insert(0, "127.0.0.1")
    peer_xml = "".join(f'<Peer address="{p}"/>' for p in peers)
    return ("<CycloneDDS><Domain Id=\"any\">" + general + "<Discovery>"
            + (f"<Peers>{peer_xml}</Peers>" if peer_xml else "")
            + "<ParticipantIndex>auto</ParticipantIndex>"
            "<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>"
            "</Discovery></Domain></CycloneDDS>")


def ensure_domain(domain_id: int) -> None:
    """Create the Cyclone domain with our configuration once per process (a no-op when the
    user's CYCLONEDDS_URI applies). Must run before the first participant on that domain."""
    config = cyclone_config()
    if config is None:
        return
    with _LOCK:
        if domain_id not in _DOMAINS:
            _DOMAINS[domain_id] = Domain(domain_id, config)
