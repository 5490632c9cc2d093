"""A typing test (not run by pytest): mypy checks it in CI (.ci/run) against the installed
package and its stub, so that an event's kind and fields keep their types. A wrong type below
fails mypy (`assert_type`), and so does a field read from the wrong kind (the `type: ignore`s
are checked by `warn_unused_ignores`)."""

from typing import List, assert_type

import skin
from skin.events import EventDict, EventKind, Footprint, GateAction


def on_line(line: EventDict) -> None:
    if line["event"] == "classified":
        assert_type(line["class"], str)
        assert_type(line["probability"], float)
        assert_type(line["border_mm"], float)
        line["duration"]  # type: ignore[typeddict-item]  # a released event's field
    elif line["event"] == "released":
        assert_type(line["peak"], Footprint)
        assert_type(line["frames"], int)
    elif line["event"] == "gate":
        assert_type(line["action"], GateAction)
    elif line["event"] == "across_joint":
        assert_type(line["links"], List[str])
    elif line["event"] == "counter_reset":
        assert_type(line["from"], int)


def on_event(session: skin.Session) -> None:
    for event in session.run_log("fixtures/session/session.candump.log"):
        assert_type(event.kind, EventKind)
        on_line(event.to_dict())
        if event.kind == "nope":  # type: ignore[comparison-overlap]  # no such kind
            pass
