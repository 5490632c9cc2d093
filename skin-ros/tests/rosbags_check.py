"""Checks messages and type hashes written by skin-ros against rosbags, an independent ROS 2
reader: every CDR message must equal rosbags' serialisation of the same values, and every
RIHS01 hash rosbags' hash_rihs01 (skin_msgs registered from its .msg files).

Usage: rosbags_check.py CASES.json SKIN_MSGS_DIR
CASES.json: {"messages": [{"type", "value", "cdr"(hex)}], "hashes": {type: hash}}
"""
import json
import re
import sys
from pathlib import Path

import numpy
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.interfaces import Nodetype

DTYPES = {
    'bool': numpy.bool_, 'byte': numpy.uint8, 'char': numpy.uint8, 'int8': numpy.int8,
    'uint8': numpy.uint8, 'int16': numpy.int16, 'uint16': numpy.uint16, 'int32': numpy.int32,
    'uint32': numpy.uint32, 'int64': numpy.int64, 'uint64': numpy.uint64,
    'float32': numpy.float32, 'float64': numpy.float64,
}


def typestore(msg_dir):
    store = get_typestore(Stores.ROS2_JAZZY)
    added = {}
    for path in sorted(Path(msg_dir).glob('*.msg')):
        added.update(get_types_from_msg(path.read_text(), f'skin_msgs/msg/{path.stem}'))
    for path in sorted((Path(msg_dir).parent / 'srv').glob('*.srv')):
        request, response = path.read_text().split('---\n')
        for part, text in (('Request', request), ('Response', response)):
            # A bare message name in a .srv is one of the package's messages.
            text = re.sub(r'^([A-Z]\w*)', r'skin_msgs/\1', text, flags=re.M)
            types = get_types_from_msg(text, f'skin_msgs/srv/{path.stem}_{part}')
            # rosbags names them pkg/srv/msg/Name: as rosidl does, pkg/srv/Name.
            added.update({k.replace('/srv/msg/', '/srv/'): v for k, v in types.items()})
    store.register(added)
    return store


def build(store, typ, value):
    fields = store.fielddefs[typ][1]
    missing = {name for name, _ in fields} ^ set(value)
    if missing:
        raise ValueError(f'{typ}: fields differ from the definition: {sorted(missing)}')
    return store.types[typ](**{name: convert(store, desc, value[name]) for name, desc in fields})


def convert(store, desc, value):
    kind, rest = desc
    if kind == Nodetype.NAME:
        return build(store, rest, value)
    if kind == Nodetype.BASE:
        name = rest[0]
        if name == 'string':
            return value
        if name == 'bool':
            return bool(value)
        if name.startswith('float'):
            return float(value)
        return int(value)
    sub, _count = rest
    if sub[0] == Nodetype.BASE and sub[1][0] != 'string':
        return numpy.array(value, dtype=DTYPES[sub[1][0]])
    return [convert(store, sub, v) for v in value]


def main():
    cases = json.loads(Path(sys.argv[1]).read_text())
    store = typestore(sys.argv[2])
    bad = 0
    for case in cases['messages']:
        typ = case['type']
        ours = bytes.fromhex(case['cdr'])
        theirs = bytes(store.serialize_cdr(build(store, typ, case['value']), typ))
        if ours != theirs:
            bad += 1
            first = next((i for i, (a, b) in enumerate(zip(ours, theirs)) if a != b), min(len(ours), len(theirs)))
            print(f'{case["name"]} ({typ}): CDR differs at byte {first} ({len(ours)} vs {len(theirs)} bytes)')
        else:
            store.deserialize_cdr(ours, typ)
            print(f'{case["name"]} ({typ}): {len(ours)} bytes equal')
    for typ, ours in cases['hashes'].items():
        if typ not in store.types or typ == 'service_msgs/msg/ServiceEventInfo':
            # Services (rosbags has no service types) and ServiceEventInfo (rosbags hashes its
            # char[16] as IDL char, rosidl as uint8): held to std_srvs/Trigger's published hash
            # by skin-ros's own test instead.
            print(f'{typ}: not hashed by rosbags')
            continue
        theirs = store.hash_rihs01(typ)
        if ours != theirs:
            bad += 1
            print(f'{typ}: hash {ours} != rosbags {theirs}')
    print(f'{len(cases["hashes"])} hashes checked')
    sys.exit(1 if bad else 0)


main()
