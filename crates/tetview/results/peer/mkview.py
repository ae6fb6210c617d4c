#!/usr/bin/env python3
# The camera vtk_render.py recorded (its JSON) as a tetview view JSON: mkview.py IN.json OUT.json
import json, sys
d = json.load(open(sys.argv[1]))
c = d["results"][0]["camera"]
v = {"position": c["position"], "focal_point": c["focal_point"], "view_up": c["view_up"],
     "view_angle": c["view_angle_deg"], "parallel": c["parallel"], "parallel_scale": c["parallel_scale"],
     "size": d["size"]}
json.dump(v, open(sys.argv[2], "w"), indent=1)
