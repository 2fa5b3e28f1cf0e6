"""Mitsuba 3 XML scenes for the comparisons of tests/test_mitsuba_parity.py, written into a
folder together with the files they use (an EXR environment map, a .vol grid, OBJ and PLY). Each takes the
parameters `spp` and `res` (square image) through <default>, so one file serves both renderers."""
import numpy as np
import trimesh

from clrender import grids
from clrender.image import save_image


def _scene(body, integrator="path", max_depth=8, origin="0 1.2 5", target="0 -0.2 0", fov=36,
           hide_emitters=False):
    return f"""<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="res" value="16"/>
    <integrator type="{integrator}">
        <integer name="max_depth" value="{max_depth}"/>
        <boolean name="hide_emitters" value="{str(hide_emitters).lower()}"/>
    </integrator>
    <sensor type="perspective">
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


def grid_medium(use_grid_bbox=False):
    """A grid whose unit cube is placed at [-0.9, 0.9]^3 (above the floor) either by to_world or
    by the .vol file's own bounding box (use_grid_bbox), inside a null cube of the same size."""
    placement = ("""<boolean name="use_grid_bbox" value="true"/>""" if use_grid_bbox else """
                <transform name="to_world">
                    <scale value="1.8"/>
                    <translate value="-0.9, -0.9, -0.9"/>
                </transform>""")
    return _scene(FLOOR + SUN + SKY + f"""
    <shape type="cube">
        <transform name="to_world">
            <scale value="0.9"/>
        </transform>
        <bsdf type="null"/>
        <medium type="heterogeneous" name="interior">
            <volume type="gridvolume" name="sigma_t">
                <string name="filename" value="cloud.vol"/>{placement}
            </volume>
            <rgb name="albedo" value="0.95, 0.9, 0.8"/>
            <float name="scale" value="6"/>
            <phase type="hg">
                <float name="g" value="-0.3"/>
            </phase>
        </medium>
    </shape>""", integrator="volpathmis", max_depth=16)


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
    path = folder / f"{name}.xml"
    path.write_text(SCENES[name]())
    return path
