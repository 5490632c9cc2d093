"""Layouts from every format, tactile maps equal to `skin flatten`'s, written and read back."""

import numpy as np
import pytest

import skin
from conftest import FIXTURES, run_skin, shared


def check_link(link: skin.Link) -> None:
    n = len(link)
    assert n > 0
    assert link.ids.shape == (n,) and link.ids.dtype == np.uint32
    assert link.positions.shape == (n, 3) and link.positions.dtype == np.float64
    assert link.normals.shape == (n, 3)
    np.testing.assert_allclose(np.linalg.norm(link.normals, axis=1), 1.0, atol=1e-9)
    # Metres: a robot link is well under 3 m across.
    assert np.ptp(link.positions, axis=0).max() < 3.0
    assert len(set(link.ids.tolist())) == n
    if link.faces is not None:
        assert link.faces.shape[1] == 3
        assert link.faces.min() >= 0 and link.faces.max() < n


def test_project_layout_one_link():
    layout = skin.read_layout(FIXTURES / "forearm" / "layout.json")
    assert layout.names == ["forearm"] and len(layout) == 1
    link = layout["forearm"]
    check_link(link)
    assert len(link) == 715
    assert layout[0].name == layout[-1].name == "forearm"
    with pytest.raises(KeyError, match="forearm"):
        layout["elbow"]


def test_project_layout_two_links():
    layout = skin.read_layout(FIXTURES / "arm" / "layout.json")
    assert layout.names == ["forearm", "wrist"]
    for link in layout.links:
        check_link(link)


def test_urdf_with_tactile_sensors(tmp_path):
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(
        """<robot name="r"><link name="base"/><link name="arm"/>
  <sensor name="a" update_rate="50"><parent link="base"/><origin xyz="0 0 0.1"/>
    <tactile><array rows="8" cols="6" size="0.006 0.006"/></tactile></sensor>
  <sensor name="b" update_rate="50"><parent link="arm"/>
    <tactile><array rows="5" cols="5" size="0.008 0.008"/></tactile></sensor>
</robot>"""
    )
    layout = skin.read_layout(urdf)
    assert layout.names == ["base", "arm"]
    assert [len(link) for link in layout.links] == [48, 25]
    for link in layout.links:
        check_link(link)
    # An array of 6 mm cells: neighbouring taxels 6 mm apart, in metres.
    p = layout["base"].positions
    d = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    assert d.min() == pytest.approx(0.006, abs=1e-9)


def test_real_cyskin_patch():
    layout = skin.read_layout(shared("cyskin", "curved_gesture_patch.json"))
    check_link(layout[0])


def test_real_icub_taxel_file():
    layout = skin.read_layout(shared("icub", "left_forearm_V2.txt"))
    check_link(layout[0])
    cli = run_skin("flatten", shared("icub", "left_forearm_V2.txt"), "-o", "/dev/null")
    # The reader's notes are what the command line says on reading the file.
    for note in layout.notes:
        assert note in cli.stdout + cli.stderr


def test_link_from_arrays_round_trips():
    src = skin.read_layout(FIXTURES / "forearm" / "layout.json")[0]
    link = skin.Link("copy", src.ids, src.positions, src.normals, src.faces)
    np.testing.assert_array_equal(link.ids, src.ids)
    np.testing.assert_array_equal(link.positions, src.positions)
    np.testing.assert_allclose(link.normals, src.normals, atol=1e-15)
    a, b = skin.flatten(src), skin.flatten(link)
    np.testing.assert_array_equal(a.uv, b.uv)


def test_flatten_equals_skin_flatten(tmp_path):
    out = tmp_path / "map.json"
    run_skin("flatten", FIXTURES / "forearm" / "layout.json", "-o", out)
    cli = skin.read_map(out)
    ours = skin.flatten(skin.read_layout(FIXTURES / "forearm" / "layout.json")[0])
    np.testing.assert_array_equal(ours.ids, cli.ids)
    np.testing.assert_array_equal(ours.uv, cli.uv)
    np.testing.assert_array_equal(ours.faces, cli.faces)
    assert ours.uv.shape == (715, 2) and ours.uv.dtype == np.float64


def test_flatten_report_is_the_commands(tmp_path):
    done = run_skin("flatten", FIXTURES / "forearm" / "layout.json", "-o", tmp_path / "m.json")
    tmap = skin.flatten(skin.read_layout(FIXTURES / "forearm" / "layout.json")[0])
    assert tmap.report.strip() in done.stdout + done.stderr
    d = tmap.distortion
    assert 0 <= d["angle_error_mean_deg"] <= d["angle_error_p95_deg"]
    assert d["flipped_faces"] == 0


def test_triangulate_option_matches_the_command(tmp_path):
    out = tmp_path / "map.json"
    run_skin("flatten", FIXTURES / "hex_patch" / "layout.json", "-o", out, "--triangulate", "--max-edge", "2.5")
    ours = skin.flatten(skin.read_layout(FIXTURES / "hex_patch" / "layout.json")[0], triangulate=True, max_edge=2.5)
    np.testing.assert_array_equal(ours.uv, skin.read_map(out).uv)


def test_map_write_and_read_back(tmp_path):
    tmap = skin.flatten(skin.read_layout(FIXTURES / "forearm" / "layout.json")[0])
    path = tmp_path / "forearm.json"
    tmap.write(path)
    back = skin.read_map(path)
    np.testing.assert_array_equal(back.uv, tmap.uv)
    np.testing.assert_array_equal(back.ids, tmap.ids)
    # A map is replaced by a map...
    tmap.write(path)
    # ...never a file that is not one.
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes")
    with pytest.raises(skin.InputError, match="notes.txt"):
        tmap.write(notes)
    assert notes.read_text() == "my notes"
    cyskin = tmp_path / "forearm.cyskin.json"
    tmap.write(cyskin, format="cyskin")
    np.testing.assert_allclose(skin.read_map(cyskin).uv, tmap.uv, atol=1e-6)


def test_read_map_flattens_a_layout():
    a = skin.read_map(FIXTURES / "forearm" / "layout.json")
    b = skin.flatten(skin.read_layout(FIXTURES / "forearm" / "layout.json")[0])
    np.testing.assert_array_equal(a.uv, b.uv)


def test_border_mm_is_each_taxels_way_to_the_nearest_border_edge():
    """Against numpy: the edges of one triangle only, the distance to the nearest segment."""
    m = skin.read_map(FIXTURES / "forearm" / "layout.json")
    count = {}
    for f in m.faces:
        for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0])):
            key = (min(a, b), max(a, b))
            count[key] = count.get(key, 0) + 1
    edges = np.array([e for e, n in count.items() if n == 1])
    a, b = m.uv[edges[:, 0]], m.uv[edges[:, 1]]
    ab = b - a
    rel = m.uv[:, None, :] - a[None]
    t = np.clip(np.einsum("pkd,kd->pk", rel, ab) / np.einsum("kd,kd->k", ab, ab), 0.0, 1.0)
    want = np.linalg.norm(rel - t[..., None] * ab[None], axis=2).min(axis=1) * 1e3
    assert m.border_mm.shape == (len(m),)
    np.testing.assert_allclose(m.border_mm, want, atol=1e-9)
    # The forearm's map is nearly a rectangle: its border taxels are 0 from it, its middle far.
    assert (m.border_mm == 0).sum() >= 40 and m.border_mm.max() > 80
