"""A camera mounted low stands on free floor, never inside a furnished region."""

import genie_gl as gg


def test_low_mounts_stand_where_nothing_is_furnished():
    sensor = gg.load_sensor("zivid2_m70")
    for name in ("logistics_lane", "assembly_line"):
        layout = gg.generate_layout(name, seed=0)
        furnished = [r for r in layout.leaves() if layout.region_types[r.type].asset_group]
        low = gg.place_sensors(layout, sensor, n=4, seed=0, method="greedy", mount_height_m=0.9)
        for pose in low:
            x, y = pose[:2, 3]
            assert not any(r.x < x < r.x + r.w and r.y < y < r.y + r.h for r in furnished), (
                name,
                x,
                y,
            )
    # a high mount may stand over furniture: the rule is for low mounts only
    high = gg.place_sensors(layout, gg.load_sensor("realsense_d435"), n=8, seed=0, method="greedy")
    assert any(
        any(r.x < p[0, 3] < r.x + r.w and r.y < p[1, 3] < r.y + r.h for r in furnished)
        for p in high
    )
