"""A sky's record is made once per sky (every input's request and stages name one):
each record must still get a dict of its own."""

from startrack.sky import SkySpec
from startrack.solver import sky_record


def test_sky_record_is_a_new_dict_each_time():
    sky = SkySpec(kind="hipparcos", mag_limit=6.0)
    first = sky_record(sky)
    first["kind"] = "changed"
    second = sky_record(sky)
    assert second["kind"] == "hipparcos" and second is not first
    assert "seed" not in second and "n_stars" not in second
    random_sky = sky_record(SkySpec())
    assert random_sky["kind"] == "random" and "seed" in random_sky
