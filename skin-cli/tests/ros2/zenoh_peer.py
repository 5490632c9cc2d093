"""A Zenoh peer (eclipse-zenoh, independent of skin) on loopback that records every sample
under 0/** and every liveliness token under @ros2_lv/**, and checks them as rmw_zenoh
subscribers would, against a run's events.jsonl.

Usage: zenoh_peer.py listen|connect PORT EVENTS.jsonl
listen: the peer listens on tcp/127.0.0.1:PORT (skin run --zenoh connects to it); connect: it
connects to skin run --zenoh-listen there, retrying until skin listens.
Prints "ready" once subscribed; the test writes a line to stdin when skin is done.
"""
import signal
import struct
import sys
import threading
import time

import zenoh

from common import events, fail, typestore

TYPES = {
    'pressure': 'sensor_msgs/msg/PointCloud2',
    'tactile_image': 'sensor_msgs/msg/Image',
    'contacts': 'skin_msgs/msg/Contacts',
    'events': 'skin_msgs/msg/TouchEvent',
    'markers': 'visualization_msgs/msg/MarkerArray',
    'wrench': 'geometry_msgs/msg/WrenchStamped',
    'tactile_state': 'skin_msgs/msg/TactileState',
    'layout': 'skin_msgs/msg/TactileLayout',
}


def dds(name):
    pkg, msg, short = name.split('/')
    return f'{pkg}::{msg}::dds_::{short}_'


def main():
    mode, port, events_path = sys.argv[1], sys.argv[2], sys.argv[3]
    signal.alarm(120)  # a bounded wait, whatever happens
    conf = zenoh.Config()
    conf.insert_json5('mode', '"peer"')
    if mode == 'listen':
        conf.insert_json5('listen/endpoints', f'["tcp/127.0.0.1:{port}"]')
    else:
        # Late, as a subscriber started by hand would be: the run must hold its first frame
        # for us (--zenoh-wait), or the replay is over before we connect.
        time.sleep(3.0)
        conf.insert_json5('connect/endpoints', f'["tcp/127.0.0.1:{port}"]')
        conf.insert_json5('connect/timeout_ms', '60000')
        conf.insert_json5('connect/exit_on_failure', 'false')
        conf.insert_json5('listen/endpoints', '[]')
    conf.insert_json5('scouting/multicast/enabled', 'false')
    lock = threading.Lock()
    samples, tokens = [], []

    def on_sample(s):
        with lock:
            samples.append((str(s.key_expr), bytes(s.payload.to_bytes()),
                            bytes(s.attachment.to_bytes()) if s.attachment is not None else None))

    def on_token(s):
        with lock:
            tokens.append((str(s.key_expr), str(s.kind)))

    session = zenoh.open(conf)
    sub = session.declare_subscriber('0/**', on_sample)
    live = session.liveliness().declare_subscriber('@ros2_lv/**', on_token, history=True)
    print('ready', flush=True)
    sys.stdin.readline()
    time.sleep(1.0)  # late samples
    sub.undeclare()
    live.undeclare()
    session.close()

    store = typestore()
    problems = []
    lines, _ = events(events_path)
    put = [k for k, kind in tokens if 'PUT' in kind.upper()]
    nodes = [k for k in put if '/NN/' in k]
    if not any(k.endswith('/NN/%/%/skin') for k in nodes):
        problems.append(f'no node token for skin: {nodes}')
    publishers = [k for k in put if '/MP/' in k]
    seen_topics = set()
    last_seq = {}
    event_json = []
    for key, payload, attachment in samples:
        if '/@adv/' in key:
            continue  # the layout's cache heartbeats (zenoh-ext's, as rmw_zenoh's)
        parts = key.split('/')
        domain, topic, ty, type_hash = parts[0], parts[1:-2], parts[-2], parts[-1]
        kind = topic[-1]
        name = TYPES.get(kind)
        if domain != '0' or name is None:
            problems.append(f'unexpected key {key}')
            continue
        if ty != dds(name) or type_hash != store.hash_rihs01(name):
            problems.append(f'{key}: type or hash is not rmw_zenoh\'s for {name}')
            continue
        topic_name = '/' + '/'.join(topic)
        seen_topics.add(topic_name)
        if attachment is None or len(attachment) != 33 or attachment[16] != 0x10:
            problems.append(f'{key}: attachment {attachment!r}')
            continue
        seq, stamp = struct.unpack_from('<qq', attachment)
        if seq <= last_seq.get(key, 0) or stamp <= 0:
            problems.append(f'{key}: sequence {seq} after {last_seq.get(key)}')
        last_seq[key] = seq
        if payload[:4] != b'\x00\x01\x00\x00':
            problems.append(f'{key}: CDR header {payload[:4]!r}')
        message = store.deserialize_cdr(payload, name)
        if kind == 'events':
            event_json.append(message.json)
        mangled = topic_name.replace('/', '%')
        if not any(f'/{mangled}/{ty}/{type_hash}/' in p for p in publishers):
            problems.append(f'{topic_name}: no publisher token')
    for kind in TYPES:
        if kind in ('pressure', 'tactile_image', 'wrench', 'tactile_state'):
            if not any(t.endswith('/' + kind) for t in seen_topics):
                problems.append(f'no {kind} topic seen')
        elif f'/skin/{kind}' not in seen_topics:
            problems.append(f'/skin/{kind} not seen')
    missing = [line for line in lines if line not in event_json]
    if missing:
        problems.append(f'{len(missing)} of {len(lines)} events not received, first: {missing[0]}')
    print(f'{len(samples)} samples on {len(seen_topics)} topics, {len(publishers)} publisher tokens, '
          f'{len(nodes)} node token(s), {len(event_json)} event samples for {len(lines)} events')
    fail(problems)


main()
