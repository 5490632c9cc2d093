"""RIHS01 hashes of services, computed by rosbags (independent of skin), printed as
`NAME HASH` lines: std_srvs/srv/Trigger (whose hash rmw_zenoh's design document gives, a fixed
point for this method) and every .srv of the repository's skin_msgs.

rosbags hashes messages, not services; rosidl hashes a service as a type holding three fields,
request_message, response_message and event_message (`Name_Event`: a ServiceEventInfo and at most
one request and one response), an empty request holding `uint8
structure_needs_at_least_one_member`. Registered so, rosbags gives the service's hash. rosidl
reads ServiceEventInfo's `char[16] client_gid` as uint8 (the IDL it makes of a .msg writes char
so); rosbags' stores keep char, so a copy of the Jazzy store with that one field as uint8 is
used.
"""
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

ROOT = Path(__file__).resolve().parents[3]
EVENT_INFO = 'service_msgs/msg/ServiceEventInfo'


def store():
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    types = dict(jazzy.fielddefs)
    consts, fields = types[EVENT_INFO]
    types[EVENT_INFO] = (consts, [(n, t) if n != 'client_gid' else (n, t.__class__((t[0], ((t[1][0][0], ('uint8', 0)), t[1][1])))) for n, t in fields])
    s = get_typestore(Stores.EMPTY)
    s.register(types)
    added = {}
    for path in sorted((ROOT / 'skin_msgs' / 'msg').glob('*.msg')):
        added.update(get_types_from_msg(path.read_text(), f'skin_msgs/msg/{path.stem}'))
    s.register(added)
    return s


def rosidl_name(x, service):
    """rosbags names the types of `pkg/srv/Name` `pkg/srv/msg/Name...`, and a message its fields
    name without a package `pkg/srv/msg/Other`: back to rosidl's names (the service's own types
    under srv/, the package's messages under msg/), everywhere."""
    if isinstance(x, str):
        fixed = x.replace('/srv/msg/', '/srv/')
        if fixed != x and not fixed.startswith(service):
            return x.replace('/srv/msg/', '/msg/')
        return fixed
    if isinstance(x, dict):
        return {rosidl_name(k, service): rosidl_name(v, service) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return type(x)(rosidl_name(v, service) for v in x)
    return x


def service_hash(s, name, text):
    request, response = (part.strip() for part in text.split('---'))
    empty = 'uint8 structure_needs_at_least_one_member'
    types = {}
    types.update(get_types_from_msg(request or empty, f'{name}_Request'))
    types.update(get_types_from_msg(response or empty, f'{name}_Response'))
    types.update(get_types_from_msg(
        f'{EVENT_INFO} info\n{name}_Request[<=1] request\n{name}_Response[<=1] response', f'{name}_Event'))
    types.update(get_types_from_msg(
        f'{name}_Request request_message\n{name}_Response response_message\n{name}_Event event_message', name))
    s.register(rosidl_name(types, name))
    return s.hash_rihs01(name)


def main():
    s = store()
    print('std_srvs/srv/Trigger', service_hash(s, 'std_srvs/srv/Trigger', '---\nbool success\nstring message'))
    for path in sorted((ROOT / 'skin_msgs' / 'srv').glob('*.srv')):
        # The .srv's comments are not part of its type.
        text = '\n'.join(line.split('#', 1)[0] for line in path.read_text().splitlines())
        name = f'skin_msgs/srv/{path.stem}'
        print(name, service_hash(s, name, text))


if __name__ == '__main__':
    main()
