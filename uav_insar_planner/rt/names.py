"""ROS 2 name resolution and the rmw_cyclonedds mapping of ROS names to DDS topic names."""
from __future__ import annotations

import re

_TOKEN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def topic_to_dds(fq_name: str) -> str:
    """`/chatter` -> `rt/chatter`."""
    return "rt" + fq_name


def service_to_dds(fq_name: str) -> tuple[str, str]:
    """`/planner/replan` -> (`rq/planner/replanRequest`, `rr/planner/replanReply`)."""
    return "rq" + fq_name + "Request", "rr" + fq_name + "Reply"


def dds_to_topic(dds_name: str) -> str | None:
    """`rt/chatter` -> `/chatter`; None for a name that is not a ROS topic."""
    return dds_name[2:] if dds_name.startswith("rt/") else None


def validate_node_name(name: str) -> None:
    """Raise ValueError unless `name` is a valid ROS node name."""
    if not _TOKEN.match(name):
        raise ValueError(f"invalid node name {name!r}: use letters, digits and underscores, "
                         "not starting with a digit")


def normalize_namespace(ns: str) -> str:
    """'' or 'a/b' or '/a/b/' -> '/' or '/a/b'; raise ValueError for bad tokens."""
    tokens = [tok for tok in ns.strip("/").split("/") if tok]
    for tok in tokens:
        if not _TOKEN.match(tok):
            raise ValueError(f"invalid namespace {ns!r}")
    return "/" + "/".join(tokens)


def resolve(name: str, namespace: str, node_name: str) -> str:
    """Expand a topic or service name to its fully qualified form, as rcl does.

    Absolute names stay; `~` is the node's private namespace; relative names are put under the
    node's namespace. Raises ValueError for an invalid name.
    """
    if name.startswith("~"):
        base = namespace.rstrip("/") + "/" + node_name
        name = base + name[1:]
    elif not name.startswith("/"):
        name = namespace.rstrip("/") + "/" + name
    tokens = name[1:].split("/")
    if not name[1:] or any(not _TOKEN.match(tok) for tok in tokens):
        raise ValueError(f"invalid topic or service name {name!r}")
    return name
