"""Which emitter next-event estimation picks (clrender/light_selection.py): half by power (the
environment's a quarter of it), half as Mitsuba 3 (each emitting shape and each light alike, a
mesh's triangles by area)."""
import warnings

import numpy as np

import clrender
from clrender.arrays import build_scene_arrays
from clrender.light_selection import selection_weights


def test_small_lights_beside_a_powerful_one_keep_half_of_a_uniform_share():
    # Veach's MIS scene: lights of power 200, 1, 1, 1, 1. By power the small ones got 0.5 % each.
    weights = selection_weights([200.0, 1, 1, 1, 1], [1.0] * 5, range(5))
    assert np.isclose(weights.sum(), 1.0)
    np.testing.assert_allclose(weights, 0.5 * np.array([200, 1, 1, 1, 1]) / 204 + 0.5 / 5)


def test_a_meshs_triangles_share_its_uniform_half_by_area():
    # Two triangles of one shape (areas 1 and 3) and a point light: each group gets 1/4 from
    # the uniform half, split by area within the shape.
    weights = selection_weights([0.0, 0.0, 4.0], [1.0, 3.0, 1.0], [7, 7, 9])
    np.testing.assert_allclose(weights, [0.5 / 2 / 4, 0.5 / 2 * 3 / 4, 0.5 + 0.5 / 2])


def arrays_of_xml(folder, shapes_and_emitters):
    """The scene arrays of a Mitsuba scene of these shapes and emitters, seen by an 8 x 8 film."""
    path = folder / "scene.xml"
    path.write_text(f"""<scene version="3.0.0">{shapes_and_emitters}
        <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    </scene>""")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clrender.MitsubaXmlWarning)   # the default filter
        return build_scene_arrays(clrender.load_scene(path))


def test_the_scene_arrays_pick_emitters_by_these_weights(tmp_path):
    # A large dim rectangle (two triangles, power pi x 4 x 0.1), a tiny bright sphere (power
    # pi x 4 pi 0.01^2 x 100) and a point light (power 4 pi x 2): the emitter CDF's steps.
    arrays = arrays_of_xml(tmp_path, """
        <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="0.1"/></emitter></shape>
        <shape type="sphere"><float name="radius" value="0.01"/><point name="center" x="0" y="0" z="3"/>
            <emitter type="area"><rgb name="radiance" value="100"/></emitter></shape>
        <emitter type="point"><point name="position" x="0" y="0" z="5"/><rgb name="intensity" value="2"/></emitter>""")
    powers = np.array([np.pi * 4 * 0.1, np.pi * 4 * np.pi * 0.01**2 * 100, 4 * np.pi * 2])
    by_power = powers / powers.sum()
    expected = 0.5 * np.array([by_power[0] / 2, by_power[0] / 2, by_power[1], by_power[2]]) + 0.5 * np.array([1 / 6, 1 / 6, 1 / 3, 1 / 3])
    np.testing.assert_allclose(np.diff(arrays.emitter_cdf), expected, rtol=1e-5)


def test_the_environment_counts_a_quarter_of_its_power_beside_a_sun(tmp_path):
    # A constant sky of radiance 0.4 and a sun of irradiance 2 in a scene of bounding radius r:
    # powers 4 pi^2 r^2 0.4 (toon's shares) and pi r^2 2; for picking, the sky's counts a quarter,
    # the irradiance pi L of the half of it a surface sees against the sun's E.
    arrays = arrays_of_xml(tmp_path, """
        <shape type="rectangle"><bsdf type="diffuse"/></shape>
        <emitter type="constant"><rgb name="radiance" value="0.4"/></emitter>
        <emitter type="directional"><vector name="direction" x="0" y="0" z="-1"/><rgb name="irradiance" value="2"/></emitter>""")
    sky, sun = np.pi * np.pi * 0.4, np.pi * 2.0   # over r^2
    np.testing.assert_allclose(np.diff(arrays.emitter_cdf), 0.5 * np.array([sky, sun]) / (sky + sun) + 0.25, rtol=1e-5)
    np.testing.assert_allclose(arrays.emitters["e2"][:, 3], np.array([4 * sky, sun]) / (4 * sky + sun), rtol=1e-5)
