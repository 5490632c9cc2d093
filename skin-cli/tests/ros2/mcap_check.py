"""Reads an MCAP of `skin run --mcap` with the `mcap` and `mcap-ros2-support` packages
(independent of skin) and checks it against the run's events.jsonl.

Usage: mcap_check.py FILE.mcap EVENTS.jsonl FRAMES LINK...
FRAMES: frames after the baseline (one PointCloud2 per link each). EVENTS.jsonl may be `-`
(skin convert: no events file) to check the file and the clouds only.
"""
import json
import math
import struct
import sys
import tomllib
from collections import Counter
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from common import events, fail, typestore


def main():
    path, events_path, frames, links = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4:]
    lines, parsed = events(events_path) if events_path != '-' else ([], [])
    store = typestore()
    problems = []
    with open(path, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        if header.profile != 'ros2':
            problems.append(f'profile {header.profile!r}, not ros2')
        summary = reader.get_summary()
        for channel in summary.channels.values():
            schema = summary.schemas[channel.schema_id]
            if channel.message_encoding != 'cdr' or schema.encoding != 'ros2msg':
                problems.append(f'{channel.topic}: {channel.message_encoding}/{schema.encoding}')
            qos = channel.metadata.get('offered_qos_profiles', '')
            if 'reliability:' not in qos or 'history:' not in qos:
                problems.append(f'{channel.topic}: no offered_qos_profiles')
            # Events are offered keep-all (never dropped), the frame topics keep-last.
            history = 'keep_all' if channel.topic.endswith('/events') else 'keep_last'
            if f'history: {history}' not in qos:
                problems.append(f'{channel.topic}: offered QoS is not {history}')
            if channel.metadata.get('topic_type_hash') != store.hash_rihs01(schema.name):
                problems.append(f'{channel.topic}: type hash differs from rosbags')
        counts = Counter()
        event_json = []
        images = Counter()
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            counts[channel.topic] += 1
            if channel.topic == '/skin/events':
                event_json.append(decoded.json)
                if decoded.header.frame_id != decoded.link:
                    problems.append(f'event frame_id {decoded.header.frame_id!r} != link {decoded.link!r}')
            if schema.name == 'sensor_msgs/msg/Image':
                images[channel.topic] += 1
                if decoded.encoding == 'mono8' and len(decoded.data) != decoded.height * decoded.width:
                    problems.append(f'{channel.topic}: image size')
            if schema.name == 'sensor_msgs/msg/PointCloud2':
                if decoded.width * decoded.point_step != len(decoded.data):
                    problems.append(f'{channel.topic}: cloud size')
            # rosbags decodes the same bytes too.
            store.deserialize_cdr(message.data, schema.name)
    missing = [line for line in lines if line not in event_json]
    if missing:
        problems.append(f'{len(missing)} events.jsonl lines have no /skin/events message, first: {missing[0]}')
    for link in links:
        n = counts[f'/skin/{link}/pressure']
        if n != frames:
            problems.append(f'/skin/{link}/pressure: {n} clouds for {frames} frames')
    decisions = Counter(e['link'] for e in parsed if e['event'] == 'classified')
    for link, n in decisions.items():
        if images[f'/skin/{link}/tactile_image'] != n:
            problems.append(f'{link}: {images[f"/skin/{link}/tactile_image"]} images for {n} decisions')
    problems += as_rosbag2(path, counts)
    problems += forces(path, parsed, frames, links, counts)
    problems += tactile(path, frames, links, counts)
    print(f'{sum(counts.values())} messages on {len(counts)} topics; {len(lines)} events; {sum(decisions.values())} decisions')
    fail(problems)


def as_rosbag2(path, counts):
    """The file as a rosbag2 reader sees it (rosbags' own MCAP storage, which is what `ros2 bag
    play FILE.mcap` does without ROS): the same topics and counts, a QoS profile on every
    connection, and every message decoded from the definitions in the file alone (skin_msgs
    not registered beforehand)."""
    problems = []
    with Reader(Path(path)) as bag:
        seen = {c.topic: c.msgcount for c in bag.connections if c.msgcount}
        if seen != dict(counts):
            problems.append(f'rosbag2 reader counts {seen}, mcap reader {dict(counts)}')
        for c in bag.connections:
            if not c.ext.offered_qos_profiles:
                problems.append(f'{c.topic}: rosbag2 reader finds no QoS profile')
    with AnyReader([Path(path)], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as bag:
        decoded = sum(1 for c, _, raw in bag.messages() if bag.deserialize(raw, c.msgtype) is not None)
        if decoded != sum(counts.values()):
            problems.append(f'AnyReader decoded {decoded} of {sum(counts.values())}')
    return problems


def forces(path, parsed, frames, links, counts):
    """With a force calibration (events carry force_n): a wrench per frame on every link, and
    at each touch's first frame the contacts' forces, decoded by rosbags from the definitions
    in the file alone, add up to the appeared event's force_n within 1e-6 N, the wrench's force
    no larger."""
    appeared = [e for e in parsed if e['event'] == 'appeared' and 'force_n' in e]
    if not appeared:
        return []
    problems = []
    for link in links:
        if counts[f'/skin/{link}/wrench'] != frames:
            problems.append(f'/skin/{link}/wrench: {counts[f"/skin/{link}/wrench"]} wrenches for {frames} frames')
    by_stamp = {}
    with AnyReader([Path(path)], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as bag:
        wanted = [c for c in bag.connections if c.topic in ('/skin/events', '/skin/contacts') or c.topic.endswith('/wrench')]
        for c, _, raw in bag.messages(connections=wanted):
            m = bag.deserialize(raw, c.msgtype)
            stamp = (m.header.stamp.sec, m.header.stamp.nanosec)
            if c.topic == '/skin/events':
                if json.loads(m.json)['event'] == 'appeared':
                    by_stamp.setdefault(stamp, {})['event'] = json.loads(m.json)
            elif c.topic == '/skin/contacts':
                by_stamp.setdefault(stamp, {})['contacts'] = m.contacts
            elif c.topic.endswith('/wrench'):
                by_stamp.setdefault(stamp, {})[c.topic] = m.wrench
    checked = 0
    for at in by_stamp.values():
        e = at.get('event')
        if e is None or 'force_n' not in e:
            continue
        mine = [c.force for c in at.get('contacts', []) if c.header.frame_id == e['link']]
        if abs(sum(mine) - e['force_n']) > 1e-6:
            problems.append(f'touch {e["touch"]}: contacts {sum(mine)} N, event {e["force_n"]} N')
        w = at.get(f'/skin/{e["link"]}/wrench')
        size = math.sqrt(w.force.x ** 2 + w.force.y ** 2 + w.force.z ** 2) if w else -1
        if not 0 < size <= e['force_n'] + 1e-6:
            problems.append(f'touch {e["touch"]}: wrench {size} N against {e["force_n"]} N')
        checked += 1
    if checked != len(appeared):
        problems.append(f'{checked} of {len(appeared)} touches found with their contacts and wrench')
    print(f'forces of {checked} touches checked against the events')
    return problems


def tactile(path, frames, links, counts):
    """The skin's description and readings, decoded by rosbags from the definitions in the
    file alone: one TactileLayout, the file's first message, agreeing with the layout file the
    run's configuration names (ids, positions to 1e-6 m); a TactileState per frame per link
    whose readings equal the cloud's pressures (counts), or on a calibrated link (N) add up to
    its contacts' forces and are zero on a frame without contact."""
    problems = []
    if counts['/skin/layout'] != 1:
        return [f'{counts["/skin/layout"]} layout messages, not 1']
    with AnyReader([Path(path)], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as bag:
        first = next(iter(bag.messages()))
        if first[0].topic != '/skin/layout':
            problems.append(f'the first message is on {first[0].topic}, not /skin/layout')
        layout = bag.deserialize(first[2], first[0].msgtype)
        by_stamp = {}
        wanted = [c for c in bag.connections
                  if c.topic.endswith('/tactile_state') or c.topic.endswith('/pressure') or c.topic == '/skin/contacts']
        for c, _, raw in bag.messages(connections=wanted):
            m = bag.deserialize(raw, c.msgtype)
            by_stamp.setdefault((m.header.stamp.sec, m.header.stamp.nanosec), {})[c.topic] = m
    # The layout file (skin-layout/1) where the configuration names one; other layouts (a
    # Cyskin patch) against the point clouds, which carry each taxel's id and position too.
    config = Path(layout.source)
    layout_file = config.parent / tomllib.loads(config.read_text())['layout']
    native = json.loads(layout_file.read_text())
    if 'links' in native:
        want = {l['name']: ([t['id'] for t in l['taxels']], [t['position'] for t in l['taxels']])
                for l in native['links']}
        against = str(layout_file)
    else:
        want, against = {}, 'the point clouds'
        for at in by_stamp.values():
            for topic, m in at.items():
                if topic.endswith('/pressure'):
                    link = m.header.frame_id
                    step = m.point_step
                    field = {f.name: f.offset for f in m.fields}
                    def value(k, name, kind='<f'):
                        return struct.unpack_from(kind, bytes(m.data), k * step + field[name])[0]
                    want.setdefault(link, ([value(k, 'id', '<I') for k in range(m.width)],
                                           [[value(k, n) for n in 'xyz'] for k in range(m.width)]))
    units = {}
    for link in layout.links:
        units[link.link] = link.units
        w = want.get(link.link)
        if w is None:
            problems.append(f'layout: link {link.link} is not in {against}')
            continue
        if list(link.taxel_ids) != w[0]:
            problems.append(f'layout: {link.link}: ids differ from {against}')
        far = max(abs(a - b) for p, t in zip(link.positions, w[1]) for a, b in zip((p.x, p.y, p.z), t))
        if far > 1e-6:
            problems.append(f'layout: {link.link}: a position is {far} m off {against}')
    checked = 0
    for link in links:
        if counts[f'/skin/{link}/tactile_state'] != frames:
            problems.append(f'/skin/{link}/tactile_state: {counts[f"/skin/{link}/tactile_state"]} for {frames} frames')
        for at in by_stamp.values():
            state = at.get(f'/skin/{link}/tactile_state')
            if state is None:
                continue
            if state.units != units.get(link):
                problems.append(f'{link}: state in {state.units}, layout says {units.get(link)}')
            readings = [r for i, r in enumerate(state.readings) if i not in set(state.dead)]
            if state.units == 'counts':
                cloud = at[f'/skin/{link}/pressure']
                step, offset = cloud.point_step, next(f.offset for f in cloud.fields if f.name == 'pressure')
                pressures = [struct.unpack_from('<f', bytes(cloud.data), k * step + offset)[0]
                             for k in range(cloud.width)]
                pressures = [p for i, p in enumerate(pressures) if i not in set(state.dead)]
                if readings != pressures:
                    problems.append(f'{link}: readings differ from the cloud at {state.header.stamp}')
            else:
                mine = [c.force for c in (at['/skin/contacts'].contacts if '/skin/contacts' in at else [])
                        if c.header.frame_id == link]
                if abs(sum(readings) - sum(mine)) > 1e-3 + 1e-4 * abs(sum(mine)):
                    problems.append(f'{link}: readings add up to {sum(readings)} N, contacts {sum(mine)} N')
            checked += 1
    print(f'layout and {checked} tactile states checked')
    return problems


main()
