"""A network lab of Linux network namespaces joined by a user-space switch that loses, delays
and cuts Ethernet frames per port (the radio links between the ground station and the UAVs).

    tap.py       open a TAP device (/dev/net/tun), the switch's end of one port
    impair.py    the per-port, per-direction impairment (loss, delay +- jitter, cut), seeded
    control.py   the control grammar (`set`, `cut`, `restore`, `stats`) and its client
    switch.py    the switch process (`python -m uav_insar_sim.netlab.switch`)
    lab.py       NetLab: namespaces, one switch port each, addresses, routes, processes
    dds_env.py   the environment a ROS 2 process needs to talk across the lab (measured facts)

The planner never imports this package (simulation only).
"""
