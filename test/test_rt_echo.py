"""`python -m uav_insar_planner.echo` against a real publisher process."""
from __future__ import annotations

import yaml


def test_echo_formation_type_from_discovery(children):
    talker = children.start("talker")
    assert talker.stdout.readline().strip() == "ready"
    result = children.run("/formation", "--count", "1", "--timeout", "15",
                          module="uav_insar_planner.echo")
    assert result.returncode == 0, result.stderr
    text, sep, rest = result.stdout.partition("---\n")
    assert sep and rest == ""
    doc = yaml.safe_load(text)
    assert doc["header"]["frame_id"] == "insar_track"
    assert [p["position"]["x"] for p in doc["poses"]] == [0.0, 10.0, 20.0]
    assert doc["poses"][0]["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    assert text.startswith("header:\n  stamp:\n    sec: 0\n    nanosec: 0\n")

    chatter = children.run("chatter", "--count", "2", "--timeout", "15",
                           module="uav_insar_planner.echo")
    assert chatter.returncode == 0, chatter.stderr
    docs = [d for d in chatter.stdout.split("---\n") if d]
    assert len(docs) == 2 and all(yaml.safe_load(d)["data"].startswith("hello") for d in docs)


def test_echo_without_publisher_times_out(children):
    result = children.run("/nobody", "--timeout", "0.5", module="uav_insar_planner.echo")
    assert result.returncode == 1
    assert "no publisher on /nobody" in result.stderr
