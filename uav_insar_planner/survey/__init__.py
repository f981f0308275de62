"""Survey an area: lay the straight stripmap passes whose radar swaths cover a polygon, group
them into sorties that fit a battery, and choose the speed with a certificate. Science: no ROS,
no MAVLink; `model`, `solver/`, `track/`, `mavlink/` and the simulator never import it.

- `area`: read the area (GeoJSON or KML polygon) and project it to metres about the home;
- `strips`: the parallel strips (swath bands, boustrophedon order) and the best bearing;
- `coverage`: the brute-force check of how much of the area the strips' swaths image;
- `sorties`: the strips in flight order, in sorties within endurance x (1 - reserve);
- `speed`: v_y as a decision variable: the fastest speed for a sigma_h target, certified;
- `planning`: the whole survey planned (`plan_survey` -> `SurveyPlan`);
- `survey_file`: the planned survey as `survey.json`, and its reader (`SurveyFile`);
- `flown_coverage`: the planned and the flown sigma_h over the area's cells (coverage map).
"""
