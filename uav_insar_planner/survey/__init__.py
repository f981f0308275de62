"""Survey an area: lay the straight stripmap passes whose radar swaths cover a polygon.

- `area`: read the area (GeoJSON or KML polygon) and project it to metres about the home;
- `strips`: the parallel strips (swath bands, boustrophedon order) and the best bearing;
- `coverage`: the brute-force check of how much of the area the strips' swaths image.
"""
