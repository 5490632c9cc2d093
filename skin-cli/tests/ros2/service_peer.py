"""A Zenoh peer (eclipse-zenoh) that uses a running `skin run --zenoh-listen` as an rmw_zenoh
node would: it calls PREFIX/describe and PREFIX/tare (std_srvs/srv/Trigger) as an rmw_zenoh
client calls a service (a query to the service's key, the 33-byte attachment with its
sequence number and GID, a CDR request), subscribes late to the transient-local PREFIX/layout
as rmw_zenoh's transient-local subscribers do (zenoh-ext's advanced subscriber with history),
and feeds the run its log through a FIFO, so that it knows where the run is.

Usage: service_peer.py PORT FIFO LOG LAYOUT.json DESCRIBE_HASH
Checks, failing with the reasons:
- describe's reply decodes as skin_msgs/srv/Describe_Response (rosbags, from the repository's
  .srv) and equals the layout file (ids, positions to 1e-6 m);
- tare while the baseline is learned is refused, saying so; between two touches it succeeds;
  during a touch (once its "appeared" event arrived) a tare is refused with the reason, and
  tare_forced succeeds; each reply decodes as
  std_srvs/srv/Trigger_Response and echoes the request's sequence number and GID;
- the layout reaches a subscriber that joins after the run started, and equals describe's.
Prints each service call's round trip (ms).
"""
import json
import os
import signal
import struct
import sys
import threading
import time

import numpy
import zenoh
import zenoh.ext

from rosbags.typesys import get_types_from_msg

from common import ROOT, fail, typestore

DOMAIN = 0
# std_srvs/srv/Trigger's, as rmw_zenoh's design document gives it; Describe's from the command
# line (rosbags hashes no service).
HASHES = {'std_srvs/srv/Trigger': 'RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f'}


def store_with_services():
    store = typestore()
    added = get_types_from_msg('bool success\nstring message\n', 'std_srvs/srv/Trigger_Response')
    text = (ROOT / 'skin_msgs' / 'srv' / 'Describe.srv').read_text().split('---\n')[1]
    added.update(get_types_from_msg(text.replace('TactileLayout', 'skin_msgs/TactileLayout'),
                                    'skin_msgs/srv/Describe_Response'))
    store.register({k.replace('/srv/msg/', '/srv/'): v for k, v in added.items()})
    return store


class Client:
    """An rmw_zenoh service client: its GID, its sequence numbers from 1."""

    def __init__(self, session, store):
        self.session, self.store = session, store
        self.gid = os.urandom(16)
        self.seq = 0
        self.rtts = []

    def key(self, service, srv_type):
        pkg, _, name = srv_type.split('/')
        return f'{DOMAIN}/{service.lstrip("/")}/{pkg}::srv::dds_::{name}_/{HASHES[srv_type]}'

    def call(self, service, srv_type, response_type):
        self.seq += 1
        attachment = struct.pack('<qqB', self.seq, time.time_ns(), 16) + self.gid
        start = time.perf_counter()
        replies = list(self.session.get(
            self.key(service, srv_type), payload=b'\x00\x01\x00\x00\x00', attachment=attachment,
            target=zenoh.QueryTarget.ALL_COMPLETE, consolidation=zenoh.ConsolidationMode.NONE,
            timeout=10.0))
        self.rtts.append((time.perf_counter() - start) * 1e3)
        oks = [r.ok for r in replies if r.ok is not None]
        if len(oks) != 1:
            raise RuntimeError(f'{service}: {len(oks)} replies ({[r.err for r in replies]})')
        sample = oks[0]
        back = bytes(sample.attachment.to_bytes())
        seq, _stamp = struct.unpack_from('<qq', back)
        if len(back) != 33 or seq != self.seq or back[17:] != self.gid:
            raise RuntimeError(f'{service}: the reply does not echo sequence {self.seq} and the GID')
        return self.store.deserialize_cdr(bytes(sample.payload.to_bytes()), response_type)


def check_layout(msg, layout, what, problems):
    links = {l['name']: l for l in layout['links']}
    for link in msg.links:
        want = links.get(link.link)
        if want is None:
            problems.append(f'{what}: link {link.link} is not in the layout')
            continue
        ids = [t['id'] for t in want['taxels']]
        if list(link.taxel_ids) != ids:
            problems.append(f'{what}: {link.link}: taxel ids differ from the layout file')
        got = numpy.array([[p.x, p.y, p.z] for p in link.positions])
        exp = numpy.array([t['position'] for t in want['taxels']])
        if got.shape != exp.shape or numpy.abs(got - exp).max() > 1e-6:
            problems.append(f'{what}: {link.link}: positions differ from the layout file by more than 1e-6 m')
        if len(link.areas) != len(ids) or len(link.modules) != len(ids) or link.units not in ('counts', 'N'):
            problems.append(f'{what}: {link.link}: areas, modules or units missing')
    if len(msg.links) != len(links):
        problems.append(f'{what}: {len(msg.links)} links, the layout has {len(links)}')


def main():
    port, fifo, log, layout_path = sys.argv[1:5]
    HASHES['skin_msgs/srv/Describe'] = sys.argv[5]
    signal.alarm(180)
    layout = json.loads(open(layout_path).read())
    store = store_with_services()
    conf = zenoh.Config()
    conf.insert_json5('mode', '"peer"')
    conf.insert_json5('connect/endpoints', f'["tcp/127.0.0.1:{port}"]')
    conf.insert_json5('connect/timeout_ms', '60000')
    conf.insert_json5('connect/exit_on_failure', 'false')
    conf.insert_json5('listen/endpoints', '[]')
    conf.insert_json5('scouting/multicast/enabled', 'false')
    conf.insert_json5('timestamping/enabled', 'true')
    session = zenoh.open(conf)
    problems = []
    appeared, released = threading.Event(), threading.Event()

    def on_event(sample):
        msg = store.deserialize_cdr(bytes(sample.payload.to_bytes()), 'skin_msgs/msg/TouchEvent')
        event = json.loads(msg.json)
        # The first touch's release (1 to 2 s), then the third touch (4 to 5 s) under way.
        if event['event'] == 'released':
            released.set()
        if event['event'] == 'appeared' and event['time'] >= 3.9:
            appeared.set()

    events_sub = session.declare_subscriber(f'{DOMAIN}/skin/events/*/*', on_event)
    client = Client(session, store)
    # The services are there before the run reads its log; wait until the peer is connected.
    for _ in range(300):
        try:
            described = client.call('/skin/describe', 'skin_msgs/srv/Describe', 'skin_msgs/srv/Describe_Response')
            break
        except RuntimeError:
            time.sleep(0.1)
    else:
        fail(['/skin/describe never answered'])
    check_layout(described.layout, layout, 'describe', problems)

    lines = open(log).read().splitlines(keepends=True)
    t0 = float(lines[0].split(')')[0].strip('('))
    with open(fifo, 'w') as out:
        def write_until(t):
            while lines and float(lines[0].split(')')[0].strip('(')) < t0 + t:
                out.write(lines.pop(0))
            out.flush()

        # While the baseline is learned (its first second): refused, saying so.
        write_until(0.5)
        reply = client.call('/skin/tare', 'std_srvs/srv/Trigger', 'std_srvs/srv/Trigger_Response')
        if reply.success or 'being learned' not in reply.message:
            problems.append(f'tare while the baseline is learned: success {reply.success}, "{reply.message}"')
        # Between the first touch and the second: taken.
        write_until(2.3)
        if not released.wait(60):
            problems.append('the first touch was not released')
        reply = client.call('/skin/tare', 'std_srvs/srv/Trigger', 'std_srvs/srv/Trigger_Response')
        if not reply.success:
            problems.append(f'tare between touches refused: {reply.message}')
        # Inside the third touch (4.0 to 5.0 s of the log, after the re-learned baseline).
        write_until(4.6)
        if not appeared.wait(60):
            problems.append('no touch appeared')
        reply = client.call('/skin/tare', 'std_srvs/srv/Trigger', 'std_srvs/srv/Trigger_Response')
        if reply.success or 'touch' not in reply.message:
            problems.append(f'tare during a touch: success {reply.success}, "{reply.message}"')
        print(f'tare during a touch: refused, "{reply.message}"')
        reply = client.call('/skin/tare_forced', 'std_srvs/srv/Trigger', 'std_srvs/srv/Trigger_Response')
        if not reply.success:
            problems.append(f'tare_forced refused: {reply.message}')
        # A subscriber that joins late still gets the layout.
        got = []
        late = zenoh.ext.declare_advanced_subscriber(
            session, f'{DOMAIN}/skin/layout/*/*', lambda s: got.append(bytes(s.payload.to_bytes())),
            history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1))
        for _ in range(100):
            if got:
                break
            time.sleep(0.05)
        if not got:
            problems.append('a late subscriber did not get the layout')
        else:
            check_layout(store.deserialize_cdr(got[0], 'skin_msgs/msg/TactileLayout'), layout, 'layout', problems)
        late.undeclare()
        write_until(1e9)
    events_sub.undeclare()
    session.close()
    rtts = sorted(client.rtts)
    print(f'{len(rtts)} service calls, round trip median {rtts[len(rtts) // 2]:.2f} ms, '
          f'max {rtts[-1]:.2f} ms')
    fail(problems)


main()
