"""Press the fixture forearm in MuJoCo and print the session's events: a ball, a bar and a hand,
one after the other, on the skin of `fixtures/forearm` simulated where each taxel sits. Run from
the repository root (needs `pip install mujoco`): python python/examples/sim_press.py"""

import mujoco

import skin
from skin.sim import Kit, SkinBridge, SkinLoop, bare_robot

config = "fixtures/session/run.toml"                    # layout, bus map, models, gate, [sim]
bridge = SkinBridge.from_config(config)                  # the skin: 715 taxels, their response
spec = bare_robot(bridge.layout)                         # a fixed body per link (or your robot)
kit = Kit(spec)                                          # tools to press with
kit.add_sphere(radius=0.03)
kit.add_bar(radius=0.015)
kit.add_hand()
bridge.attach(spec)                                      # sensor surface and cover on the body
model = spec.compile()
data = mujoco.MjData(model)
kit.bind(model, data)

top, up = [0.0, 0.18, 0.08], [0.0, 0.0, 1.0]             # the forearm's top line, metres
kit.press("sphere", top, up, 8.0, start=1.5, duration=1.0)                    # newtons, seconds
kit.press("bar", top, up, 10.0, start=3.0, duration=1.0, yaw=0.3)
kit.press("hand", top, up, 15.0, start=4.5, duration=1.5, fingers=["index", "middle", "ring"])

loop = SkinLoop(model, data, bridge, skin.Session.from_config(config), control=kit.control)
for event in loop.run(7.0) + loop.finish():
    if event.kind in ("appeared", "classified", "gate", "released"):
        fields = {k: v for k, v in event.to_dict().items() if k not in ("event", "image")}
        print(f"{event.time:5.2f} s  {event.kind:10s} {fields}")
