"""The autopilot flavours, as plain data (no MAVLink library, no ROS): `profiles` holds one
`AutopilotProfile` a flavour and the flavour list the parameter tables offer. It imports
nothing of the suite, so the parameter tables, the MAVLink side and the mission files all
read it without an import running back up.
"""
