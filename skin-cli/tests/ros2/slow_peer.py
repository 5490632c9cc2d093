"""A slow Zenoh subscriber (eclipse-zenoh, independent of skin) on loopback: its callback
sleeps DELAY seconds a sample in Zenoh's own receiving thread, so that the run feels it as a
robot's overloaded node would (the connection fills and the publisher must wait or drop).
It checks that every event of the run's events.jsonl arrived, once, in order.

Usage: slow_peer.py listen|connect PORT KEY DELAY EVENTS.jsonl|-
KEY: what it subscribes to, `0/**` (every topic) or `0/skin/events/**` (the events only).
listen: the peer listens on tcp/127.0.0.1:PORT (skin run --zenoh connects to it); connect: it
connects to skin run --zenoh-listen there. Prints "ready" once subscribed; the test writes a
line to stdin when skin is done, then the peer works through what it has (its callback is
still slow) until nothing has come for 3 s, and checks (`-`: no events to check).
"""
import signal
import sys
import threading
import time

import zenoh

from common import events, fail, typestore

EVENT_TYPE = 'skin_msgs/msg/TouchEvent'


def main():
    mode, port, key, delay, events_path = sys.argv[1:6]
    delay = float(delay)
    signal.alarm(900)  # a bounded wait, whatever happens
    conf = zenoh.Config()
    conf.insert_json5('mode', '"peer"')
    endpoint = f'["tcp/127.0.0.1:{port}"]'
    if mode == 'listen':
        conf.insert_json5('listen/endpoints', endpoint)
    else:
        conf.insert_json5('connect/endpoints', endpoint)
        conf.insert_json5('connect/timeout_ms', '60000')
        conf.insert_json5('connect/exit_on_failure', 'false')
        conf.insert_json5('listen/endpoints', '[]')
    conf.insert_json5('scouting/multicast/enabled', 'false')
    lock = threading.Lock()
    payloads = []  # the events' CDR, in the order they came
    others = [0]
    last = [time.monotonic()]

    def on_sample(s):
        time.sleep(delay)  # the slow part, in Zenoh's receiving thread
        with lock:
            if '/events/' in str(s.key_expr):
                payloads.append(bytes(s.payload.to_bytes()))
            else:
                others[0] += 1
            last[0] = time.monotonic()

    session = zenoh.open(conf)
    sub = session.declare_subscriber(key, zenoh.handlers.Callback(on_sample, indirect=False))
    print('ready', flush=True)
    sys.stdin.readline()
    started = time.monotonic()
    while True:
        time.sleep(0.2)
        with lock:
            idle = time.monotonic() - last[0]
        if idle > 3.0 + delay:
            break
    drained = time.monotonic() - started
    sub.undeclare()
    session.close()

    store = typestore()
    got = [store.deserialize_cdr(p, EVENT_TYPE).json for p in payloads]
    lines, _ = events(events_path) if events_path != '-' else (got, None)
    problems = []
    if got != lines:
        missing = [line for line in lines if line not in got]
        problems.append(f'{len(got)} event samples for {len(lines)} events: {len(missing)} missing '
                        f'(first: {missing[:1]}), {len(got) - len(set(got))} repeated, or out of order')
    print(f'{len(got)} event samples for {len(lines)} events, {others[0]} other samples; '
          f'worked {drained:.1f} s after the run ended')
    fail(problems)


main()
