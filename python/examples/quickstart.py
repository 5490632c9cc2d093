"""The README's ten lines: a layout, its tactile map, images of a recording, and the fixture
session's decisions. Run from the repository root: python python/examples/quickstart.py"""

import skin

layout = skin.read_layout("fixtures/forearm/layout.json")
tmap = skin.flatten(layout["forearm"])                    # uv: (715, 2) metres on the map
rec = skin.read_recording("fixtures/forearm/touches.txt")
frames = rec.for_taxels(tmap.ids, threshold=3.0)         # (T, 715) readings in map order
images = skin.Imager(tmap, size=(68, 100)).images(frames) # (T, 68, 100) uint8
session = skin.Session.from_config("fixtures/session/run.toml")
for event in session.run_log("fixtures/session/session.candump.log"):
    if event.kind == "released" and event["class"] is not None:  # None: released undecided
        print(f"touch {event.touch} at {event.time:5.2f} s: {event['class']} ({event.probability:.3f})")
print(f"{len(images)} images of {images.shape[1]} x {images.shape[2]} px; {session.stats['touches']} touches")
