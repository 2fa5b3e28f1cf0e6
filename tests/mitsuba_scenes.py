"""Mitsuba 3 XML scenes for the comparisons of tests/test_mitsuba_parity.py, written into a
folder together with the files they use (an EXR environment map, a .vol grid, OBJ and PLY). Each takes the
parameters `spp` and `res` (square image) through <default>, so one file serves both renderers."""
import numpy as np
import trimesh

from clrender import grids
from clrender.image import save_image


def _scene(body, integrator="path", max_depth=8, origin="0 1.2 5", target="0 -0.2 0", fov=36,
           hide_emitters=False, sensor="perspective", lens="", properties=None):
    """`properties`: the integrator's, instead of max_depth."""
    properties = properties or f'<integer name="max_depth" value="{max_depth}"/>'
    return f"""<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="res" value="16"/>
    <integrator type="{integrator}">
        {properties}
        <boolean name="hide_emitters" value="{str(hide_emitters).lower()}"/>
    </integrator>
    <sensor type="{sensor}">{lens}
        <float name="fov" value="{fov}"/>
        <transform name="to_world">
            <lookat origin="{origin}" target="{target}" up="0 1 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="$res"/>
            <integer name="height" value="$res"/>
            <rfilter type="box"/>
        </film>
    </sensor>
{body}
</scene>
"""


FLOOR = """
    <shape type="rectangle">
        <transform name="to_world">
            <scale value="4"/>
            <rotate x="1" angle="-90"/>
            <translate y="-1"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.6, 0.5, 0.4"/>
        </bsdf>
    </shape>"""

SUN = """
    <emitter type="directional">
        <vector name="direction" x="-0.4" y="-1" z="-0.3"/>
        <rgb name="irradiance" value="3, 2.8, 2.5"/>
    </emitter>"""

SKY = """
    <emitter type="constant">
        <rgb name="radiance" value="0.3, 0.4, 0.5"/>
    </emitter>"""


def glass_sphere():
    return _scene(FLOOR + SUN + SKY + """
    <shape type="sphere">
        <bsdf type="dielectric">
            <string name="int_ior" value="bk7"/>
        </bsdf>
    </shape>""")


def rough_glass():
    return _scene(FLOOR + SUN + SKY + """
    <shape type="sphere">
        <float name="radius" value="0.9"/>
        <bsdf type="roughdielectric">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.25"/>
            <float name="int_ior" value="1.5"/>
            <rgb name="specular_transmittance" value="0.9, 0.95, 1"/>
        </bsdf>
    </shape>""")


def homogeneous_medium():
    return _scene(FLOOR + SUN + SKY + """
    <medium type="homogeneous" id="smoke">
        <rgb name="sigma_t" value="0.3, 0.6, 1.0"/>
        <rgb name="albedo" value="0.9, 0.8, 0.7"/>
        <float name="scale" value="2.5"/>
        <phase type="hg">
            <float name="g" value="0.4"/>
        </phase>
    </medium>
    <shape type="sphere">
        <bsdf type="null"/>
        <ref name="interior" id="smoke"/>
    </shape>""", integrator="volpath", max_depth=16)


def _grid_placement(use_grid_bbox):
    """A gridvolume's unit cube at [-0.9, 0.9]^3: by to_world, or by the .vol file's own box."""
    return ("""<boolean name="use_grid_bbox" value="true"/>""" if use_grid_bbox else """
                <transform name="to_world">
                    <scale value="1.8"/>
                    <translate value="-0.9, -0.9, -0.9"/>
                </transform>""")


def grid_medium(use_grid_bbox=False, albedo='<rgb name="albedo" value="0.95, 0.9, 0.8"/>', g=-0.3,
                integrator="volpathmis"):
    """A grid whose unit cube is placed at [-0.9, 0.9]^3 (above the floor) either by to_world or
    by the .vol file's own bounding box (use_grid_bbox), inside a null cube of the same size."""
    return _scene(FLOOR + SUN + SKY + f"""
    <shape type="cube">
        <transform name="to_world">
            <scale value="0.9"/>
        </transform>
        <bsdf type="null"/>
        <medium type="heterogeneous" name="interior">
            <volume type="gridvolume" name="sigma_t">
                <string name="filename" value="cloud.vol"/>{_grid_placement(use_grid_bbox)}
            </volume>
            {albedo}
            <float name="scale" value="6"/>
            <phase type="hg">
                <float name="g" value="{g}"/>
            </phase>
        </medium>
    </shape>""", integrator=integrator, max_depth=16)


def grid_albedo(rgb=True, texture=False):
    """grid_medium with an albedo grid of its own resolution: RGB placed by to_world, or one
    channel placed by the files' bounding boxes; or that RGB grid inside a volume texture, which
    Mitsuba evaluates at the world origin only."""
    albedo = f"""<volume type="gridvolume" name="{'volume' if texture else 'albedo'}">
                <string name="filename" value="{'albedo_rgb.vol' if rgb else 'albedo_grey.vol'}"/>{_grid_placement(not rgb)}
            </volume>"""
    if texture:
        albedo = f"""<texture type="volume" name="albedo">{albedo}</texture>"""
    return grid_medium(use_grid_bbox=not rgb, albedo=albedo, g=0.3, integrator="volpath")


def direct(emitter_samples, bsdf_samples, hide_emitters=False):
    """Mitsuba's direct integrator on Veach's MIS test: emitting spheres of four sizes above rough
    conductors from sharp to blurry, a mirror ball (emitters seen in it through BSDF samples) and a
    sky. No point light: Mitsuba 3.9 counts a delta light emitter_samples times (docs/mitsuba-xml.md)."""
    spheres = "".join(f"""
    <shape type="sphere">
        <point name="center" x="{x}" y="1.4" z="-0.8"/>
        <float name="radius" value="{radius}"/>
        <emitter type="area"><rgb name="radiance" value="{radiance}"/></emitter>
    </shape>""" for x, radius, radiance in ((-1.5, 0.04, "300, 250, 200"), (-0.5, 0.12, "40, 40, 40"),
                                            (0.5, 0.3, "5, 6, 7"), (1.5, 0.6, "1.2, 1, 0.8")))
    plates = "".join(f"""
    <shape type="rectangle">
        <transform name="to_world">
            <scale x="1.8" y="0.3"/>
            <rotate x="1" angle="{angle}"/>
            <translate y="{y}" z="{z}"/>
        </transform>
        <bsdf type="roughconductor">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="{alpha}"/>
        </bsdf>
    </shape>""" for y, z, angle, alpha in ((-0.9, 1.2, -70, 0.01), (-0.7, 0.6, -60, 0.05),
                                           (-0.45, 0.0, -50, 0.15), (-0.15, -0.6, -40, 0.4)))
    properties = (f'<integer name="emitter_samples" value="{emitter_samples}"/>'
                  f'<integer name="bsdf_samples" value="{bsdf_samples}"/>')
    return _scene(FLOOR + SKY + spheres + plates + """
    <shape type="sphere">
        <point name="center" x="1.6" y="-0.6" z="0.8"/>
        <float name="radius" value="0.4"/>
        <bsdf type="conductor"/>
    </shape>""", integrator="direct", properties=properties, origin="0 1 5", target="0 0 0", fov=45,
                  hide_emitters=hide_emitters)


def hidden_emitters():
    """hide_emitters with emitting shapes seen directly (one of them from behind) and in a mirror:
    camera rays pass through them, the mirror and the lit floor still show them."""
    return _scene(FLOOR + SKY + """
    <shape type="rectangle">
        <transform name="to_world">
            <scale value="0.4"/>
            <translate x="-0.6" y="0" z="0.5"/>
        </transform>
        <emitter type="area"><rgb name="radiance" value="6, 5, 4"/></emitter>
    </shape>
    <shape type="sphere">
        <point name="center" x="0.3" y="0.1" z="0.3"/>
        <float name="radius" value="0.3"/>
        <boolean name="flip_normals" value="true"/>
        <emitter type="area"><rgb name="radiance" value="2, 3, 4"/></emitter>
    </shape>
    <shape type="rectangle">
        <transform name="to_world">
            <scale value="0.8"/>
            <rotate y="1" angle="-150"/>
            <translate x="0.4" y="0" z="-1.2"/>
        </transform>
        <bsdf type="conductor"/>
    </shape>""", hide_emitters=True)


def environment_map(hide_emitters=False):
    return _scene("""
    <emitter type="envmap">
        <string name="filename" value="sky.exr"/>
        <float name="scale" value="1.5"/>
        <transform name="to_world">
            <rotate y="1" angle="70"/>
            <rotate x="1" angle="25"/>
        </transform>
    </emitter>
    <shape type="sphere">
        <point name="center" x="-0.7" y="0" z="0"/>
        <float name="radius" value="0.6"/>
        <bsdf type="twosided">
            <bsdf type="diffuse">
                <rgb name="reflectance" value="0.8, 0.7, 0.6"/>
            </bsdf>
        </bsdf>
    </shape>
    <shape type="sphere">
        <point name="center" x="0.7" y="0" z="0"/>
        <float name="radius" value="0.6"/>
        <bsdf type="conductor">
            <rgb name="specular_reflectance" value="0.9, 0.9, 0.8"/>
        </bsdf>
    </shape>""", origin="0 0.5 4", target="0 0 0", fov=50, hide_emitters=hide_emitters)


def lights():
    """Point and directional lights; a rough conductor; an area light and a diffuse panel seen
    from behind (black: one-sided, in both renderers)."""
    return _scene(FLOOR + SUN + """
    <emitter type="point">
        <point name="position" x="1.5" y="1.5" z="1.5"/>
        <rgb name="intensity" value="4, 5, 6"/>
    </emitter>
    <shape type="sphere">
        <point name="center" x="-0.6" y="-0.4" z="0"/>
        <float name="radius" value="0.6"/>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.3, 0.6, 0.8"/>
        </bsdf>
    </shape>
    <shape type="sphere">
        <point name="center" x="0.7" y="-0.5" z="0.3"/>
        <float name="radius" value="0.5"/>
        <bsdf type="roughconductor">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.3"/>
            <rgb name="specular_reflectance" value="0.9, 0.7, 0.5"/>
        </bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world">
            <scale value="0.4"/>
            <rotate y="1" angle="180"/>
            <translate x="-0.9" y="0.9" z="0.5"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="5, 5, 5"/>
        </emitter>
    </shape>
    <shape type="disk">
        <transform name="to_world">
            <scale value="0.35"/>
            <rotate y="1" angle="180"/>
            <translate x="0.9" y="0.9" z="0.5"/>
        </transform>
        <bsdf type="diffuse"/>
    </shape>""")


def meshes():
    """An OBJ without normals (smooth: vertex normals computed from the faces) and a PLY with
    face normals, stretched and turned: mesh loading, winding and normals."""
    return _scene(FLOOR + SUN + SKY + """
    <shape type="obj">
        <string name="filename" value="ball.obj"/>
        <transform name="to_world">
            <scale x="1.3" y="0.8" z="1"/>
            <translate x="-0.8"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.7, 0.6, 0.5"/>
        </bsdf>
    </shape>
    <shape type="ply">
        <string name="filename" value="ball.ply"/>
        <boolean name="face_normals" value="true"/>
        <transform name="to_world">
            <rotate y="1" angle="30"/>
            <scale value="0.7"/>
            <translate x="1"/>
        </transform>
        <bsdf type="roughconductor">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.2"/>
        </bsdf>
    </shape>""", max_depth=4)


def depth_of_field():
    """A thin lens focused on the sphere at the centre; a smaller sphere nearer the camera, in
    front of the sky, blurs over about three pixels (a pinhole's image of it differs by |z| 6)."""
    lens = """
        <float name="aperture_radius" value="0.3"/>
        <float name="focus_distance" value="5.2"/>"""
    return _scene(FLOOR + SUN + SKY + diffuse_sphere("0, 0, 0", 0.6, "0.8, 0.3, 0.2")
                  + diffuse_sphere("0.45, 0.45, 2.6", 0.3, "0.9, 0.85, 0.2"), sensor="thinlens", lens=lens)


def spot_lights():
    """Two spot lights on the floor and a sphere: one narrow with Mitsuba's default beam, one
    wide and tilted with its own beam width, placed by a scaled lookat."""
    return _scene(FLOOR + diffuse_sphere("0.3, -0.4, 0", 0.6, "0.7, 0.7, 0.7") + """
    <emitter type="spot">
        <transform name="to_world">
            <lookat origin="-1, 2, 1" target="-0.6, -1, 0"/>
        </transform>
        <rgb name="intensity" value="20, 16, 10"/>
        <float name="cutoff_angle" value="25"/>
    </emitter>
    <emitter type="spot">
        <transform name="to_world">
            <lookat origin="2, 1, 1.5" target="0, -0.6, 0"/>
            <scale value="2"/>
        </transform>
        <rgb name="intensity" value="30, 45, 90"/>
        <float name="cutoff_angle" value="50"/>
        <float name="beam_width" value="10"/>
    </emitter>""")


def diffuse_sphere(center, radius, reflectance):
    return f"""
    <shape type="sphere">
        <point name="center" value="{center}"/>
        <float name="radius" value="{radius}"/>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="{reflectance}"/>
        </bsdf>
    </shape>"""


def textured_spheres():
    """Checkerboards on analytic spheres (Mitsuba's sphere uv, turned by to_world): a diffuse
    reflectance, a rough conductor's alpha, and an area emitter's radiance lighting the floor."""
    return _scene(FLOOR + SUN + SKY + """
    <texture type="checkerboard" id="checks">
        <rgb name="color0" value="0.8, 0.3, 0.1"/>
        <rgb name="color1" value="0.1, 0.5, 0.7"/>
        <transform name="to_uv"><scale x="6" y="3"/></transform>
    </texture>
    <shape type="sphere">
        <float name="radius" value="0.8"/>
        <transform name="to_world"><rotate x="1" angle="60"/><rotate y="1" angle="25"/><translate x="-0.9"/></transform>
        <bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf>
    </shape>
    <shape type="sphere">
        <float name="radius" value="0.6"/>
        <transform name="to_world"><rotate z="1" angle="40"/><translate x="0.9" y="-0.3"/></transform>
        <bsdf type="roughconductor">
            <string name="distribution" value="ggx"/>
            <texture type="checkerboard" name="alpha">
                <float name="color0" value="0.05"/>
                <float name="color1" value="0.5"/>
                <transform name="to_uv"><scale x="4" y="4"/></transform>
            </texture>
        </bsdf>
    </shape>
    <shape type="sphere">
        <float name="radius" value="0.3"/>
        <transform name="to_world"><translate y="1.3" z="-0.5"/></transform>
        <emitter type="area">
            <texture type="checkerboard" name="radiance">
                <rgb name="color0" value="1, 0.9, 0.6"/>
                <rgb name="color1" value="0.1, 0.3, 0.9"/>
                <transform name="to_uv"><scale x="2" y="2"/></transform>
            </texture>
        </emitter>
    </shape>""", max_depth=4)


def _sphere(center, radius, bsdf):
    """A sphere shape with the BSDF element `bsdf` (XML text)."""
    x, y, z = center
    return f"""
    <shape type="sphere">
        <point name="center" x="{x}" y="{y}" z="{z}"/>
        <float name="radius" value="{radius}"/>
        {bsdf}
    </shape>"""


def metals():
    """Conductors with complex indices: a smooth gold preset, a rough (Beckmann, Mitsuba's default)
    sphere with explicit RGB eta and k (Bitterli's scenes' values) and a tint, and a rough GGX
    copper preset, wide enough that separable masking shows."""
    return _scene(FLOOR + SUN + SKY + _sphere((-1.1, -0.4, 0), 0.55, """<bsdf type="conductor">
            <string name="material" value="Au"/>
        </bsdf>""") + _sphere((0, -0.4, 0.2), 0.55, """<bsdf type="roughconductor">
            <float name="alpha" value="0.25"/>
            <rgb name="eta" value="0.200438, 0.924033, 1.10221"/>
            <rgb name="k" value="3.91295, 2.45285, 2.14219"/>
            <rgb name="specular_reflectance" value="0.9, 0.8, 0.7"/>
        </bsdf>""") + _sphere((1.1, -0.4, 0), 0.55, """<bsdf type="roughconductor">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.5"/>
            <string name="material" value="Cu"/>
        </bsdf>"""), max_depth=6)


def beckmann_glass():
    """Rough glass with Mitsuba's default distribution (Beckmann), and a smooth dielectric whose
    reflection is tinted (specular_reflectance < 1)."""
    return _scene(FLOOR + SUN + SKY + _sphere((-0.6, 0, 0), 0.6, """<bsdf type="roughdielectric">
            <float name="alpha" value="0.3"/>
            <float name="int_ior" value="1.5"/>
            <rgb name="specular_reflectance" value="0.6, 0.8, 1"/>
        </bsdf>""") + _sphere((0.7, 0, 0), 0.6, """<bsdf type="dielectric">
            <float name="int_ior" value="1.7"/>
            <rgb name="specular_reflectance" value="0.3, 0.5, 0.7"/>
            <rgb name="specular_transmittance" value="1, 0.9, 0.8"/>
        </bsdf>"""), max_depth=10)


def thin_pane():
    """A thin dielectric pane (Mitsuba's thindielectric) standing on the floor between the camera
    and a diffuse sphere, at an angle: the sphere through it, the sky and the floor in it."""
    return _scene(FLOOR + SUN + SKY + """
    <shape type="rectangle">
        <transform name="to_world">
            <scale x="1.2" y="0.8"/>
            <rotate y="1" angle="35"/>
            <translate y="-0.2" z="1"/>
        </transform>
        <bsdf type="thindielectric">
            <float name="int_ior" value="1.6"/>
            <rgb name="specular_transmittance" value="0.9, 0.95, 1"/>
            <rgb name="specular_reflectance" value="1, 0.9, 0.8"/>
        </bsdf>
    </shape>""" + _sphere((0.2, -0.4, -0.3), 0.6, """<bsdf type="diffuse">
            <rgb name="reflectance" value="0.2, 0.6, 0.3"/>
        </bsdf>"""), max_depth=8)


def plastic_spheres():
    """Mitsuba's plastic and roughplastic (its default distribution, Beckmann) on spheres, one
    with nonlinear internal scattering and a tinted coat."""
    return _scene(FLOOR + SUN + SKY + _sphere((-0.75, -0.2, 0), 0.7, """<bsdf type="plastic">
            <rgb name="diffuse_reflectance" value="0.7, 0.2, 0.1"/>
            <float name="int_ior" value="1.5"/>
        </bsdf>""") + _sphere((0.75, -0.2, 0), 0.7, """<bsdf type="roughplastic">
            <float name="alpha" value="0.15"/>
            <rgb name="diffuse_reflectance" value="0.1, 0.3, 0.8"/>
            <rgb name="specular_reflectance" value="0.9, 0.8, 0.6"/>
            <boolean name="nonlinear" value="true"/>
        </bsdf>"""))


def textured_plastic():
    """Textured reflectances of plastics (their means weigh the lobes): a GGX roughplastic with a
    checkerboard diffuse_reflectance, a smooth nonlinear plastic with a checkerboard
    specular_reflectance, and a two-sided roughplastic floor."""
    return _scene(SUN + SKY + """
    <shape type="rectangle">
        <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><translate y="-1"/></transform>
        <bsdf type="twosided">
            <bsdf type="roughplastic">
                <string name="distribution" value="ggx"/>
                <float name="alpha" value="0.05"/>
                <rgb name="diffuse_reflectance" value="0.5, 0.45, 0.3"/>
            </bsdf>
        </bsdf>
    </shape>
    <shape type="sphere">
        <float name="radius" value="0.7"/>
        <transform name="to_world"><rotate x="1" angle="50"/><rotate y="1" angle="20"/><translate x="-0.75" y="-0.2"/></transform>
        <bsdf type="roughplastic">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.3"/>
            <texture type="checkerboard" name="diffuse_reflectance">
                <rgb name="color0" value="0.8, 0.3, 0.1"/>
                <rgb name="color1" value="0.1, 0.5, 0.7"/>
                <transform name="to_uv"><scale x="6" y="3"/></transform>
            </texture>
        </bsdf>
    </shape>
    <shape type="sphere">
        <float name="radius" value="0.7"/>
        <transform name="to_world"><rotate z="1" angle="30"/><translate x="0.75" y="-0.2"/></transform>
        <bsdf type="plastic">
            <boolean name="nonlinear" value="true"/>
            <rgb name="diffuse_reflectance" value="0.6, 0.6, 0.2"/>
            <texture type="checkerboard" name="specular_reflectance">
                <rgb name="color0" value="1, 1, 1"/>
                <rgb name="color1" value="0.2, 0.1, 0.6"/>
                <transform name="to_uv"><scale x="4" y="4"/></transform>
            </texture>
        </bsdf>
    </shape>""", origin="0 2 5", target="0 -0.5 0")


def masked_leaf():
    """A leaf-like panel masked by a bitmap (soft, bilinear) between an area light and the floor,
    and two cards with a front and a back BSDF, one seen from each side. Mitsuba's shadow rays
    stop at masks (light reaches through them by BSDF sampling), clrender's cross them: the same
    expectation."""
    return _scene(FLOOR + """
    <emitter type="constant"><rgb name="radiance" value="0.1, 0.12, 0.15"/></emitter>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.7"/><rotate x="1" angle="90"/><translate y="2.2" z="-0.3"/></transform>
        <emitter type="area"><rgb name="radiance" value="12, 11, 10"/></emitter>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.9"/><rotate x="1" angle="60"/><rotate y="1" angle="20"/>
            <translate y="0.4" z="-0.3"/></transform>
        <bsdf type="mask">
            <texture type="bitmap" name="opacity"><string name="filename" value="mask.png"/></texture>
            <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.6, 0.1"/></bsdf></bsdf>
        </bsdf>
    </shape>
    <bsdf type="twosided" id="card">
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.2"/></bsdf>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.3, 0.8"/></bsdf>
    </bsdf>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.4"/><rotate y="1" angle="30"/><translate x="-1.1" y="-0.5"/></transform>
        <ref id="card"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.4"/><rotate y="1" angle="200"/><translate x="1.1" y="-0.5"/></transform>
        <ref id="card"/>
    </shape>""", max_depth=12)


def bent_normals():
    """A bump-mapped diffuse sphere and mirror sphere, and a normal-mapped floor (raw normals)
    and sphere, lit by the sun and the sky."""
    return _scene(SUN + SKY + """
    <texture type="bitmap" id="heights"><string name="filename" value="heights.png"/></texture>
    <texture type="bitmap" id="normals">
        <string name="filename" value="normals.png"/><boolean name="raw" value="true"/>
    </texture>
    <shape type="rectangle">
        <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><translate y="-1"/></transform>
        <bsdf type="normalmap">
            <ref name="normalmap" id="normals"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf>
        </bsdf>
    </shape>
    <shape type="sphere">
        <float name="radius" value="0.6"/>
        <transform name="to_world"><rotate x="1" angle="50"/><translate x="-1" y="-0.2"/></transform>
        <bsdf type="bumpmap">
            <ref id="heights"/>
            <float name="scale" value="0.08"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.7, 0.6"/></bsdf>
        </bsdf>
    </shape>
    <shape type="sphere">
        <float name="radius" value="0.5"/>
        <transform name="to_world"><translate x="0.2" y="-0.3" z="0.4"/></transform>
        <bsdf type="bumpmap">
            <ref id="heights"/>
            <float name="scale" value="0.05"/>
            <bsdf type="conductor"><rgb name="specular_reflectance" value="0.9, 0.8, 0.7"/></bsdf>
        </bsdf>
    </shape>
    <shape type="sphere">
        <float name="radius" value="0.45"/>
        <transform name="to_world"><rotate y="1" angle="70"/><translate x="1.2" y="-0.4"/></transform>
        <bsdf type="normalmap">
            <ref name="normalmap" id="normals"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.3, 0.5, 0.8"/></bsdf>
        </bsdf>
    </shape>""", max_depth=8)


SCENES = {
    "metals": metals,
    "beckmann_glass": beckmann_glass,
    "thin_pane": thin_pane,
    "depth_of_field": depth_of_field,
    "spot_lights": spot_lights,
    "masked_leaf": masked_leaf,
    "bent_normals": bent_normals,
    "textured_spheres": textured_spheres,
    "glass_sphere": glass_sphere,
    "rough_glass": rough_glass,
    "homogeneous_medium": homogeneous_medium,
    "grid_medium": grid_medium,
    "grid_medium_bbox": lambda: grid_medium(use_grid_bbox=True),
    "environment_map": environment_map,
    "environment_map_hidden": lambda: environment_map(hide_emitters=True),
    "lights": lights,
    "meshes": meshes,
    "plastic_spheres": plastic_spheres,
    "textured_plastic": textured_plastic,
    "grid_albedo_rgb": grid_albedo,
    "grid_albedo_grey": lambda: grid_albedo(rgb=False),
    "grid_albedo_texture": lambda: grid_albedo(texture=True),
    "direct_mis": lambda: direct(2, 3),
    "direct_emitter_samples": lambda: direct(3, 0),
    "direct_bsdf_samples": lambda: direct(0, 2, hide_emitters=True),
    "hidden_emitters": hidden_emitters,
}


def sky_image(width=32, height=16):
    """A smooth lat-long sky (bilinear and constant texels then differ little): brighter
    towards one azimuth, coloured by elevation."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    azimuth = 1.0 + 0.8 * np.cos(2 * np.pi * (u - 0.3))
    elevation = np.stack([1.2 - 0.6 * v, 1.0 - 0.3 * v, 0.6 + 0.6 * v], axis=-1)
    return (azimuth[None, :, None] * elevation[:, None, :]).astype(np.float32)


def cloud_density(resolution=(12, 10, 8)):
    """A soft ball with a gradient across it: voxel placement and orientation both matter."""
    x, y, z = grids.voxel_centres(resolution)
    ball = np.clip(1.0 - np.sqrt((x - 0.5) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2) / 0.5, 0, None)
    return (ball * (0.3 + 1.4 * x) * (0.6 + 0.8 * z)).astype(np.float32)


def cloud_albedo(resolution=(5, 7, 3)):
    """RGB albedos at another resolution than the cloud's: red to blue along x, darker along y."""
    x, y, z = grids.voxel_centres(resolution)
    return np.stack([0.95 - 0.8 * x, 0.3 + 0.4 * z, 0.15 + 0.8 * x * (1 - 0.5 * y)], axis=-1).astype(np.float32)


def mask_image(size=32):
    """A leaf's opacity: 1 inside an ellipse with soft edges and a few holes, 0 outside (8-bit)."""
    u, v = np.meshgrid((np.arange(size) + 0.5) / size, (np.arange(size) + 0.5) / size)
    leaf = np.clip((1 - ((u - 0.5) / 0.45) ** 2 - ((v - 0.5) / 0.3) ** 2) * 4, 0, 1)
    holes = np.cos(7 * np.pi * u) * np.cos(5 * np.pi * v) > 0.6
    return (255 * leaf * ~holes).astype(np.uint8)


def height_image(size=16, seed=11):
    """Smooth random heights (8-bit grey, sRGB-encoded as Mitsuba reads it by default)."""
    noise = np.random.default_rng(seed).uniform(0, 1, (size, size))
    smooth = (noise + np.roll(noise, 1, 0) + np.roll(noise, 1, 1) + np.roll(noise, (1, 1), (0, 1))) / 4
    return (255 * smooth).astype(np.uint8)


def normal_image(size=16, seed=12):
    """Tangent-space normals tilted up to about 35 degrees, as (n + 1) / 2 in 8 bits."""
    rng = np.random.default_rng(seed)
    n = np.concatenate([rng.uniform(-0.4, 0.4, (size, size, 2)), np.ones((size, size, 1))], axis=2)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    return np.round(255 * (n + 1) / 2).astype(np.uint8)


def write(folder, name):
    """Write scene `name` and its data files into `folder`; returns the XML path."""
    import imageio.v3 as iio
    iio.imwrite(folder / "mask.png", mask_image())
    iio.imwrite(folder / "heights.png", height_image())
    iio.imwrite(folder / "normals.png", normal_image())
    ball = trimesh.creation.icosphere(subdivisions=3)
    (folder / "ball.obj").write_text(ball.export(file_type="obj", include_normals=False))
    (folder / "ball.ply").write_bytes(ball.export(file_type="ply"))
    save_image(sky_image(), folder / "sky.exr")
    # The bounding box is where the to_world variant places the unit cube.
    grids.write_vol(folder / "cloud.vol", cloud_density(), bbox=((-0.9,) * 3, (0.9,) * 3))
    albedo = cloud_albedo()
    grids.write_vol(folder / "albedo_rgb.vol", albedo, bbox=((-0.9,) * 3, (0.9,) * 3))
    grids.write_vol(folder / "albedo_grey.vol", albedo[..., 1], bbox=((-0.9,) * 3, (0.9,) * 3))
    path = folder / f"{name}.xml"
    path.write_text(SCENES[name]())
    return path
