"""Render the AUV model's picture for models/auv/README.md (menagerie style).

    MUJOCO_GL=egl python docs/images/make_model_picture.py

Writes models/auv/auv.png: the open-sea scene at the "cruising" keyframe, seen from a free camera
abeam and a little above, at 800 x 450.
"""

from __future__ import annotations

import mujoco
import numpy as np
from PIL import Image

from models import AUV_DIR, SCENES


def main() -> None:
    model = mujoco.MjModel.from_xml_path(str(SCENES["open_sea"]))
    model.vis.global_.offwidth, model.vis.global_.offheight = 800, 450
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("cruising").id)
    mujoco.mj_forward(model, data)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = data.xpos[model.body("auv").id]
    cam.distance, cam.azimuth, cam.elevation = 2.0, 205.0, -15.0
    opt = mujoco.MjvOption()
    opt.sitegroup[5] = 1  # show the sensor sites (polarimeter, IMU, depth, fins, thruster)
    with mujoco.Renderer(model, height=450, width=800) as r:
        r.update_scene(data, camera=cam, scene_option=opt)
        img = r.render()
    Image.fromarray(np.asarray(img)).save(AUV_DIR / "auv.png")
    print(f"wrote {AUV_DIR / 'auv.png'}")


if __name__ == "__main__":
    main()
