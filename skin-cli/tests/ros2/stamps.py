"""The headers of an MCAP of `skin run --mcap` / `skin convert --mcap`, read with the `mcap`
and `mcap-ros2-support` packages (independent of skin): per topic, the first and last header
stamp as nanoseconds, whether every message's header stamp equals its log time, and the frame
ids its headers (and its contacts' and markers') name.

Usage: stamps.py FILE.mcap
Prints one line per topic: TOPIC FIRST_NS LAST_NS MESSAGES EQUAL(0|1) FRAME_IDS (a JSON list),
then checks that stamps never go backwards on a topic.
"""
import json
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from common import fail


def main():
    topics = {}
    problems = []
    with open(sys.argv[1], 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            header = getattr(decoded, 'header', None)
            inner = [m.header for m in getattr(decoded, 'markers', [])]
            inner += [c.header for c in getattr(decoded, 'contacts', [])]
            if header is None:  # a MarkerArray: its first marker's header
                header = inner[0]
            ns = header.stamp.sec * 1_000_000_000 + header.stamp.nanosec
            first, last, n, equal, frames = topics.get(channel.topic, (ns, ns, 0, True, set()))
            if ns < last:
                problems.append(f'{channel.topic}: a stamp goes back from {last} to {ns}')
            frames |= {h.frame_id for h in [header] + inner}
            topics[channel.topic] = (first, ns, n + 1, equal and ns == message.log_time, frames)
    for topic, (first, last, n, equal, frames) in sorted(topics.items()):
        print(topic, first, last, n, int(equal), json.dumps(sorted(frames)))
    fail(problems)


main()
