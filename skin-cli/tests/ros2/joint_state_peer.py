"""A robot's joint states, published on Zenoh exactly as an rmw_zenoh node publishes
sensor_msgs/msg/JointState (eclipse-zenoh and rosbags, independent of skin): the data key
`<domain>/joint_states/sensor_msgs::msg::dds_::JointState_/<RIHS01 hash>`, the CDR of rosbags'
serialisation, the 33-byte attachment (sequence number from 1, source time, 16, the publisher's
GID) and the publisher's MP liveliness token.

Usage: joint_state_peer.py PORT clean|faults
Connects to `skin run --zenoh-listen tcp/127.0.0.1:PORT`, subscribes to its /skin/events (so
that --zenoh-wait lets the run start), then publishes the fixture arm's wrist roll every 10 ms
of the log's clock (-0.5 rad, 0 from 2 s, +0.5 rad from 4 s, as fixtures/arm/poses.json), a
second past its end.
faults: also a NaN, a message without the wrist's joint, another robot's, one stamped in the
past, and, all along, a flood of other samples on the topic (another type hash, CDR garbage,
a JointState that claims 100 million joints) as fast as it can; prints the flood's rate.
Waits for "done" on stdin before closing.
"""
import os
import signal
import struct
import sys
import threading
import time

import numpy
import zenoh

from common import typestore

T0 = 1_700_000_000  # the fixture log's clock, s
DDS = 'sensor_msgs::msg::dds_::JointState_'


def main():
    port, mode = sys.argv[1], sys.argv[2]
    signal.alarm(170)
    store = typestore()
    hash_ = store.hash_rihs01('sensor_msgs/msg/JointState')
    JointState = store.types['sensor_msgs/msg/JointState']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']

    def cdr(stamp_ns, names, positions):
        msg = JointState(
            header=Header(stamp=Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9), frame_id=''),
            name=list(names), position=numpy.array(positions, dtype=numpy.float64),
            velocity=numpy.array([], dtype=numpy.float64), effort=numpy.array([], dtype=numpy.float64))
        return bytes(store.serialize_cdr(msg, 'sensor_msgs/msg/JointState'))

    conf = zenoh.Config()
    conf.insert_json5('mode', '"peer"')
    conf.insert_json5('connect/endpoints', f'["tcp/127.0.0.1:{port}"]')
    conf.insert_json5('connect/timeout_ms', '60000')
    conf.insert_json5('connect/exit_on_failure', 'false')
    conf.insert_json5('listen/endpoints', '[]')
    conf.insert_json5('scouting/multicast/enabled', 'false')
    session = zenoh.open(conf)
    zid = str(session.zid())
    key = f'0/joint_states/{DDS}/{hash_}'
    # As rmw_zenoh declares a publisher: its liveliness token (reliable, volatile, keep last 10).
    token = session.liveliness().declare_token(
        f'@ros2_lv/0/{zid}/0/1/MP/%/%/robot_state/%joint_states/{DDS}/{hash_}/1:2:1,10:,:,:,,')
    publisher = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
    events = session.declare_subscriber('0/skin/events/**', lambda s: None)
    gid = os.urandom(16)
    seq = [0]

    def put(payload, pub=publisher):
        seq[0] += 1
        pub.put(payload, attachment=struct.pack('<qqB', seq[0], time.time_ns(), 16) + gid)

    stop = threading.Event()
    flood_count = [0, 0.0]

    def flood():
        other = session.declare_publisher(f'0/joint_states/{DDS}/RIHS01_' + '0' * 64)
        lying = bytearray(cdr(T0 * 10**9, ['wrist_roll'], [0.0]))
        struct.pack_into('<I', lying, 16, 100_000_000)  # the name count of a 1-joint message
        start = time.perf_counter()
        n = 0
        while not stop.is_set():
            put(b'\x00\x01\x00\x00' + os.urandom(40))
            put(bytes(lying))
            put(cdr(T0 * 10**9, ['wrist_roll'], [0.0]), other)
            n += 3
        flood_count[0], flood_count[1] = n, time.perf_counter() - start
        other.undeclare()

    print('ready', flush=True)
    time.sleep(1.0)  # the run's --zenoh-wait sees our subscriber
    flooder = threading.Thread(target=flood) if mode == 'faults' else None
    if flooder:
        flooder.start()
    for k in range(700):
        t = k * 0.01
        roll = -0.5 if t < 2.0 else (0.0 if t < 4.0 else 0.5)
        stamp = T0 * 10**9 + k * 10_000_000
        names, positions = ['gripper', 'wrist_roll'], [0.01, roll]
        if mode == 'faults':
            if 250 <= k < 260:
                positions = [0.01, float('nan')]
            elif 300 <= k < 310:
                names, positions = ['gripper'], [0.01]
            elif 350 <= k < 360:
                names, positions = ['head_pan', 'head_tilt'], [0.0, 0.0]
            elif 400 <= k < 410:
                stamp = T0 * 10**9
        put(cdr(stamp, names, positions))
        if mode == 'faults':
            time.sleep(0.002)  # the flood runs on beside the arm's joint states
    sys.stdin.readline()
    stop.set()
    if flooder:
        flooder.join()
        print(f'flood: {flood_count[0]} samples at {flood_count[0] / max(flood_count[1], 1e-9):.0f} a second',
              flush=True)
    events.undeclare()
    token.undeclare()
    session.close()


main()
