"""numpy dtypes that mirror the structs in kernels/types.h.

Every struct is built from 16- or 32-byte vectors (float4/int4, float8/int8), so the C layout
has no hidden padding and the numpy dtype is a plain sequence of 4- and 8-wide fields. tests/test_layout.py compiles a kernel
that reports sizeof/offsetof of each struct and compares them with these dtypes.
"""
import numpy as np

F4 = ("<f4", (4,))
I4 = ("<i4", (4,))


def _struct(*fields):
    return np.dtype([(name, kind) for name, kind in fields])


# The binary SAH tree as the builder makes it (host only: the kernel reads WIDE_BVH_NODE, which
# clrender/wide_bvh.py collapses it into).
# Two-child BVH node: each node stores the boxes of both children, so one node fetch tests both.
# For a child: *_lo.w holds (as int bits) the child node index when *_hi.w is 0, otherwise the
# first primitive in the reordered triangle array; *_hi.w holds (as int bits) the primitive count.
BVH_NODE = _struct(("left_lo", F4), ("left_hi", F4), ("right_lo", F4), ("right_hi", F4))

# Eight-wide BVH node: the boxes of up to eight children, one child per float8 lane. child: node
# index (count 0) or the first primitive slot of a leaf of `count` triangles (count > 0) or
# `-count` spheres (count < 0); an empty lane has child -1, count 0 and its box at +inf, which
# no ray enters.
F8 = ("<f4", (8,))
I8 = ("<i4", (8,))
WIDE_BVH_NODE = _struct(("lo_x", F8), ("hi_x", F8), ("lo_y", F8), ("hi_y", F8), ("lo_z", F8), ("hi_z", F8),
                        ("child", I8), ("count", I8))

# The triangles of a BVH leaf for intersecting them eight at once (clrender/triangle_blocks.py):
# lane j of each member is the leaf's triangle j (v0 and the edges e1 = v1 - v0, e2 = v2 - v0, per
# component), slot its primitive slot; lanes past the leaf's count repeat its last triangle. The
# kernel's only copy of the triangles' geometry.
TRIANGLE_BLOCK = _struct(*[(f"{name}_{axis}", F8) for name in ("v0", "e1", "e2") for axis in "xyz"], ("slot", I8))
# An analytic sphere, the record of its primitive slot (the sphere slots come first): centre_radius
# xyz the centre, w the radius, negative when flipped (front face inside); x_axis and z_axis.xyz
# its object frame's axes, z_axis.w -1 where that frame is mirrored, else +1 (its uv).
SPHERE = _struct(("centre_radius", F4), ("x_axis", F4), ("z_axis", F4))

# Per-triangle attributes: shading normals at the three vertices and integer info. normals: x, y,
# z the corners' unit normals, each packed by pack_normals, w 1 for them, 0 for a flat triangle
# (the geometric normal shades it): 16 bytes a triangle where three float4 took 48 (a third of a
# large mesh's scene arrays).
TRIANGLE_SHADING = _struct(("normals", I4))
# info: x material, y object id, z emitter index (-1 none), w media on both sides: see pack_media
TRIANGLE_INFO = _struct(("info", I4))

# A material: a header, its emission, and MATERIAL_SLOTS parameter slots. Its lanes are named in
# MATERIAL_FIELDS below; read and write them by name (field, set_field here, the accessors of
# kernels/materials/material.h in the kernels).
#
# Lane w of every slot (and of emission) is reserved for a texture reference (TEXTURE_REF_*): a
# parameter held there is a constant, or is replaced at each hit by a texture's value, before any
# material code reads it (kernels/materials/textured_params.h). So a material never knows where a
# value came from; the other lanes of a slot may hold parameters that are never textured.
MATERIAL_SLOTS = 13
MATERIAL = _struct(("kind", I4), ("maps", I4), ("emission", F4), ("slot", ("<f4", (MATERIAL_SLOTS, 4))))

# The texturable weights of a principled material, in slots 3, 4, ... (lane x).
PRINCIPLED_WEIGHTS = ("anisotropic", "metallic", "spec_trans", "spec_tint", "sheen", "sheen_tint", "clearcoat",
                      "clearcoat_gloss", "flatness")

# name -> (struct member, first lane, lanes); a member ("slot", k) is parameter slot k. Fields of
# different kinds may share lanes (a material has one kind).
#   kind, one_sided: MATERIAL_KINDS; 1 = black seen from behind its front face (Mitsuba's BSDFs
#     without `twosided`, kernels/materials/bsdf.h).
#   back_material: the material seen from behind (Mitsuba's twosided with two BSDFs), -1: this one.
#   albedo_tables: offset of the material's tables in Scene.specular_albedo (-1: none: smooth, or
#     `energy_compensation` off; kernels/materials/energy.h).
#   normal_map, bump_map: texture indices (-1: none) that bend the shading normal.
#   distribution, masking: the microfacet model of rough lobes (kernels/materials/microfacet.h):
#     MICROFACET_DISTRIBUTIONS, and MASKINGS (how masking and shadowing combine).
#   emission: radiance of an emitting material (textured: w).
#   color (textured): albedo (diffuse), tint (dielectric: transmission, conductor: reflectance),
#     base colour (toon), transmittance (interface).
#   alpha (textured): the microfacet width of rough lobes (dielectric, conductor, plastic).
#   ior / exterior_ior: indices of refraction inside and outside (dielectric, thin_dielectric,
#     plastic's coat).
#   reflection_tint (textured): the tint of reflection (dielectric, thin_dielectric, plastic:
#     Mitsuba's specular_reflectance; `color` tints transmission).
#   conductor_eta, conductor_k: the complex index of refraction eta + i k per RGB channel
#     (conductor; 0 and 0: Fresnel reflectance 1, a perfect mirror tinted by `color`).
#   plastic (kernels/materials/plastic.h): color is the diffuse_reflectance of its base,
#     reflection_tint the specular_reflectance of its coat; nonlinear 1: the base's internal
#     scattering per channel (Mitsuba's `nonlinear`); specular_sampling_weight: the probability
#     weight of the coat's lobe, from the reflectances' means (Mitsuba's); coat_alpha_range: the
#     alphas of the first and last rows of the rough coat's tables, coat_alpha_rows their count
#     (1 for a constant alpha; a textured one spans the texture's values, clrender/plastic.py;
#     0: a smooth coat).
#   normal_map, bump_map: (above) Mitsuba's normalmap and bumpmap (kernels/materials/shading_maps.h);
#     bump_scale: the height's factor.
#   masked: 1 when this material or its back material may let light through (opacity below 1 or
#     from a texture): shadow rays that hit it look at its opacity (kernels/materials/mask.h).
#   opacity (textured): the fraction of light the surface stops (1: opaque; Mitsuba's mask).
#   principled_* (Mitsuba's `principled`, kernels/materials/principled.h; color is its base_color):
#     roughness and the weights anisotropic ... flatness (textured, lane x of slots 1, 3-11), eta
#     (interior / exterior index) and Mitsuba's three lobe-sampling rates (never textured).
#   toon_*: read by MATERIAL_TOON only (kernels/materials/toon.h): shadow colour (tints the
#     shadow factor: a blocked point keeps shadow_factor x shadow_colour of its colour) and
#     factor, band count and softness, highlight size, softness and colour, rim width, colour and
#     threshold, ambient colour.
MATERIAL_FIELDS = {
    "kind": ("kind", 0, 1),
    "one_sided": ("kind", 1, 1),
    "back_material": ("kind", 2, 1),
    "albedo_tables": ("kind", 3, 1),
    "normal_map": ("maps", 0, 1),
    "bump_map": ("maps", 1, 1),
    "distribution": ("maps", 2, 1),
    "masking": ("maps", 3, 1),
    "emission": ("emission", 0, 3),
    "color": (("slot", 0), 0, 3),
    "alpha": (("slot", 1), 0, 1),
    "ior": (("slot", 2), 0, 1),
    "exterior_ior": (("slot", 2), 1, 1),
    "reflection_tint": (("slot", 3), 0, 3),
    "conductor_eta": (("slot", 4), 0, 3),
    "conductor_k": (("slot", 5), 0, 3),
    "nonlinear": (("slot", 2), 2, 1),
    "specular_sampling_weight": (("slot", 4), 0, 1),
    "coat_alpha_range": (("slot", 4), 1, 2),
    "coat_alpha_rows": (("slot", 5), 0, 1),
    "opacity": (("slot", 12), 0, 1),
    "bump_scale": (("slot", 12), 1, 1),
    "masked": (("slot", 12), 2, 1),
    "toon_shadow_color": (("slot", 3), 0, 3),
    "toon_shadow_factor": (("slot", 4), 0, 1),
    "toon_bands": (("slot", 4), 1, 1),
    "toon_band_softness": (("slot", 4), 2, 1),
    "toon_highlight_size": (("slot", 5), 0, 1),
    "toon_highlight_softness": (("slot", 5), 1, 1),
    "toon_highlight_color": (("slot", 6), 0, 3),
    "toon_rim_width": (("slot", 7), 0, 1),
    "toon_rim_color": (("slot", 8), 0, 3),
    "toon_rim_threshold": (("slot", 7), 1, 1),
    "toon_ambient": (("slot", 9), 0, 3),
    "principled_roughness": (("slot", 1), 0, 1),
    "principled_diffuse_rate": (("slot", 1), 1, 1),
    "principled_eta": (("slot", 2), 0, 1),
    "principled_specular_rate": (("slot", 2), 1, 1),
    "principled_clearcoat_rate": (("slot", 2), 2, 1),
    **{f"principled_{name}": (("slot", slot), 0, 1) for slot, name in enumerate(PRINCIPLED_WEIGHTS, start=3)},
}
# The fields a texture may drive; each owns lane w of its member for the texture reference.
TEXTURABLE_FIELDS = ("emission", "color", "alpha", "opacity", "reflection_tint", "principled_roughness",
                     *(f"principled_{name}" for name in PRINCIPLED_WEIGHTS))

# A texture (kernels/textures/texture.h). info: x kind (TEXTURE_KINDS), y first byte of its
# texels in Scene.texels, z width, w height. format: x channels (1, 3 or 4), y encoding
# (TEXEL_ENCODINGS), z filter (TEXTURE_FILTERS), w wrap mode (TEXTURE_WRAPS). to_uv_u, to_uv_v:
# the rows (xyz) of the affine map from the surface's uv to the texture's. color0, color1: the
# checkerboard's colours (xyz).
TEXTURE = _struct(("info", I4), ("format", I4), ("to_uv_u", F4), ("to_uv_v", F4), ("color0", F4),
                  ("color1", F4))

# kind.x EMITTER_*, kind.y an area emitter's primitive slot; radiance.w a texture reference of a
# textured area emitter (TEXTURE_REF_*, as materials'); see kernels/types.h for the meaning of
# p0/e1/e2 per kind.
EMITTER = _struct(("kind", I4), ("radiance", F4), ("p0", F4), ("e1", F4), ("e2", F4))

# A medium; lanes named in MEDIUM_FIELDS (accessors: kernels/media/medium_record.h).
MEDIUM = _struct(("sigma_a", F4), ("sigma_s", F4), ("params", F4), ("grid", I4), ("resolution", I4),
                 ("majorant_resolution", I4), ("to_voxel", ("<f4", (3, 4))), ("albedo_grid", I4),
                 ("albedo_resolution", I4))

# name -> (struct member, first lane, lanes). sigma_a, sigma_s: RGB coefficients in 1/length (the
# scene's scale applied), for a grid medium per unit density (sigma(x) = density(x) sigma).
# g: Henyey-Greenstein. sample_emitters: 1 where scattering vertices in the medium make a light
# sample (next-event estimation), 0 where they do not (scene.Medium). kind: MEDIUM_*. Grid media only: voxel_offset, the first voxel in the
# grid buffer; majorant_offset, the first majorant block in the majorant buffer (two floats each,
# max then min); majorant_block, a block's edge in voxels; resolution, voxels per axis;
# majorant_resolution, blocks per axis. The member to_voxel holds the three rows of the affine
# map world -> voxel coordinates [0, nx] x [0, ny] x [0, nz] (kernels/media/grid.h). A grid medium
# with an albedo grid: albedo_channels 1 or 3 (0: none; sigma_s / sigma_t is the albedo),
# albedo_offset its first float in the grid buffer, albedo_resolution its samples per axis (it
# fills the density grid's unit cube); sigma_s then holds sigma_t and sigma_a 0, and the kernel
# splits sigma_t by the albedo at each point.
MEDIUM_FIELDS = {
    "sigma_a": ("sigma_a", 0, 3),
    "sigma_s": ("sigma_s", 0, 3),
    "g": ("params", 0, 1),
    "sample_emitters": ("params", 1, 1),
    "kind": ("grid", 0, 1),
    "voxel_offset": ("grid", 1, 1),
    "majorant_offset": ("grid", 2, 1),
    "majorant_block": ("grid", 3, 1),
    "resolution": ("resolution", 0, 3),
    "majorant_resolution": ("majorant_resolution", 0, 3),
    "albedo_offset": ("albedo_grid", 0, 1),
    "albedo_channels": ("albedo_grid", 1, 1),
    "albedo_resolution": ("albedo_resolution", 0, 3),
}

# lens: x the aperture radius (0: a pinhole), y the distance of the plane in focus along forward
# (kernels/camera.h).
CAMERA = _struct(("origin", F4), ("forward", F4), ("right", F4), ("up", F4), ("lens", F4))

# The pixel reconstruction filter (kernels/filter.h, the table built by clrender/filters.py):
# kind.x PIXEL_FILTER_*; the rest is read by the tabulated filters only. support: x radius, y 1 / the
# filter's integral. shape: gaussian x -1 / (2 stddev^2), y its value at the radius; tent x
# 1 / radius. cells: the cubic coefficients (a, b, c, d) of the sampling map in each of
# FILTER_CELLS cells. edge_cdf and edge_mass (FILTER_EDGES floats each): the cumulative
# distribution of the sampled density and of the filter at -(k + 0.5), k = 0, 1, ... (0 where
# that lies beyond the radius).
FILTER_CELLS = 64
FILTER_EDGES = 16
# Every this many entries of each environment-sampling CDF are copied after the CDFs, for a
# search in two levels (clrender/arrays.py, kernels/lights.h).
ENV_CDF_BLOCK = 16
_FILTER_EDGE_TABLE = ("<f4", (FILTER_EDGES // 4, 4))
FILTER = _struct(("kind", I4), ("support", F4), ("shape", F4), ("cells", ("<f4", (FILTER_CELLS, 4))),
                 ("edge_cdf", _FILTER_EDGE_TABLE), ("edge_mass", _FILTER_EDGE_TABLE))

RENDER_PARAMS = np.dtype([
    ("camera", CAMERA),
    ("frame", I4),         # width, height, first sample, samples in this pass
    ("config", I4),        # max depth, roulette depth, seed, emitter count
    ("environment", I4),   # emitter index, image width, image height, hidden from camera rays (HIDDEN_FROM_CAMERA bits)
    ("env_lookup", I4),    # x how the environment image is looked up (ENVIRONMENT_LOOKUPS)
    ("env_to_map", ("<f4", (3, 4))),  # rows (xyz) of the rotation taking world directions into the
                                      # environment image's frame (its transform's inverse)
    ("media", I4),         # medium at the camera (-1: none), spectral MIS on (1) / off (0)
    ("volume", F4),        # grid media: x ray-marching step (voxels), y multiple scattering when marching (1/0)
    ("scene_sphere", F4),  # centre, radius
    ("lights", I4),        # x index of the first emitter that is not an area light (lights follow them)
    ("tile", I4),          # the pixels of this pass: first column, first row, width, height
    ("splat", I4),         # splatting (kernels/splat.h): the tile the samples are splatted to,
                           # inside `tile` grown by the filter's reach; width 0: no splatting
    ("splat_reach", I4),   # x: the pixels beyond its own a sample's filter reaches (splatting.reach)
    ("sampling", I4),      # x the sampler of camera paths (SAMPLERS); y, z the direct integrator's
                           # light and BSDF samples per camera hit (0, 0: path tracing)
    ("filter", FILTER),    # the pixel reconstruction filter
    ("light_paths", I4),   # x: light paths take the caustics (kernels/light_paths.h) (1) or not (0);
                           # y: camera samples per light path
    ("guide_grid", F4),    # the caustic guide's cells (kernels/guide.h): xyz the grid's lowest corner,
                           # w 1 / the cells' edge
    ("guide_cells", I4),   # xyz cells per axis, w 1: diffuse sampling uses the guide, 0: it does not
    ("guide_cone", F4),    # x the guide's share of diffuse samples, y cos of its cones' half angle,
                           # z 1 / a cone's solid angle
])

# One of a caustic guide cell's GUIDE_LOBES lobes (kernels/guide.h, clrender/guide.py): the
# direction light arrives from (xyz), w the cumulative weight of the cell's lobes up to this one
# (the last 1; 0 in an empty cell).
GUIDE_LOBES = 4
GUIDE_LOBE = _struct(("direction", F4))

# Per-pixel sums of the sample-level AOVs (kernels/aovs.h, feature AOVS), beside the colour sums
# whose w counts the samples: albedo, normal and emission (xyz) summed over the samples, colour_m2
# (xyz) the sum of squared deviations of the colour samples from their mean; w unused.
# clrender/aovs.py turns them into images.
AOV_SUMS = _struct(("albedo", F4), ("normal", F4), ("emission", F4), ("colour_m2", F4))

STRUCTS = {
    "WideBvhNode": WIDE_BVH_NODE,
    "TriangleBlock": TRIANGLE_BLOCK,
    "Sphere": SPHERE,
    "TriangleShading": TRIANGLE_SHADING,
    "TriangleInfo": TRIANGLE_INFO,
    "Material": MATERIAL,
    "Texture": TEXTURE,
    "Emitter": EMITTER,
    "Medium": MEDIUM,
    "Camera": CAMERA,
    "Filter": FILTER,
    "RenderParams": RENDER_PARAMS,
    "AovSums": AOV_SUMS,
    "GuideLobe": GUIDE_LOBE,
}

# Enumerations shared with the kernels: emitted as #defines ahead of the kernel source, so the
# values exist in one place only.
MATERIAL_KINDS = {"diffuse": 0, "dielectric": 1, "conductor": 2, "toon": 3, "interface": 4, "thin_dielectric": 5,
                  "plastic": 6, "principled": 7}
# Rough lobes: the distribution of microfacet normals, and the masking-shadowing term
# (height-correlated G2, or Mitsuba's separable G1(wo) G1(wi)).
MICROFACET_DISTRIBUTIONS = {"ggx": 0, "beckmann": 1}
MASKINGS = {"height_correlated": 0, "separable": 1}
EMITTER_KINDS = {"triangle": 0, "environment": 1, "point": 2, "directional": 3, "sphere": 4, "spot": 5}
ENVIRONMENT_MODES = {"none": 0, "constant": 1, "image": 2}
# How an environment image is looked up (kernels/lights.h): constant texels, or Mitsuba's envmap
# (bilinear between texel centres); RenderParams.env_lookup.x.
ENVIRONMENT_LOOKUPS = {"texel": 0, "mitsuba": 1}
MEDIUM_KINDS = {"homogeneous": 0, "grid": 1}
# Values of the GRID_MEDIA feature: how grid media are integrated (docs/heterogeneous-media.md).
VOLUME_METHODS = {"none": 0, "null": 1, "raymarch": 2}
# The random numbers of camera paths (render.sampler, kernels/rng.h); RenderParams.sampling.x.
SAMPLERS = {"independent": 0, "sobol": 1}
# Pixel reconstruction filters (camera.filter, kernels/filter.h); RenderParams.filter.kind.x.
PIXEL_FILTERS = {"box": 0, "gaussian": 1, "tent": 2}
# What camera rays do not see (bits of RenderParams.environment.w, kernels/path.h): the
# environment (render.hide_environment), and emitting shapes, which they pass through
# (render.hide_emitters, Mitsuba's hide_emitters: both bits).
HIDDEN_FROM_CAMERA = {"environment": 1, "emitting_shapes": 2}
# Textures (Texture.info.x), how their texels are stored (Texture.format.y: 8-bit sRGB-encoded,
# decoded at lookup; 8-bit linear; float32), filters and wrap modes (Mitsuba's bitmap names).
TEXTURE_KINDS = {"bitmap": 0, "checkerboard": 1}
TEXEL_ENCODINGS = {"srgb8": 0, "linear8": 1, "float32": 2}
TEXTURE_FILTERS = {"nearest": 0, "bilinear": 1}
TEXTURE_WRAPS = {"repeat": 0, "mirror": 1, "clamp": 2}


def member_lanes(records, member):
    """The lanes of `member` (a struct member's name, or (name, index) for an element of an
    array member) of a record or array of records."""
    if isinstance(member, tuple):
        name, index = member
        return records[name][..., index, :]
    return records[member]


def field(records, fields, name):
    """The named field `name` of a record or array of records (fields: MATERIAL_FIELDS or
    MEDIUM_FIELDS): a scalar per record, or a view of its lanes."""
    member, first, count = fields[name]
    lanes = member_lanes(records, member)[..., first:first + count]
    return lanes[..., 0] if count == 1 else lanes


def set_field(records, fields, name, value):
    """Write the named field `name` of a record or array of records."""
    member, first, count = fields[name]
    value = np.asarray(value)
    member_lanes(records, member)[..., first:first + count] = value[..., None] if count == 1 else value


# Texture references (lane w of a texturable member): none, or a texture index and how its value
# is used, as a colour (RGB) or a number (the luminance of RGB, Mitsuba's eval_1). Exact in float32.
TEXTURE_REF_NONE = -1.0


def texture_reference(index, scalar):
    """The lane-w value naming texture `index`, used as a number (`scalar`) or a colour."""
    return float(2 * index + int(scalar))


def set_texture_reference(records, name, index):
    """Make texturable field `name` of Material `records` take its value from texture `index`
    (as a number for a one-lane field, else as a colour)."""
    member, _, count = MATERIAL_FIELDS[name]
    member_lanes(records, member)[..., 3] = texture_reference(index, count == 1)


def clear_texture_references(records):
    """Every texturable lane of Material `records` holds a constant."""
    records["emission"][..., 3] = TEXTURE_REF_NONE
    records["slot"][..., 3] = TEXTURE_REF_NONE


def pack_normals(normals):
    """Unit vectors (..., 3) (any length but 0: they are normalised) as int32 (...): the
    octahedral encoding (Cigolle et al. 2014, "A Survey of Efficient Representations for
    Independent Unit Vectors"), the octahedron unfolded onto the square [-1, 1]^2, its x and y
    as snorm16 in the low and high 16 bits; within 1e-4 radians of the vector (6.4e-5 at worst
    over 200,000 random directions).
    kernels/scene.h, unpack_normal, reads them."""
    n = np.asarray(normals, np.float64)
    l1 = np.sum(np.abs(n), axis=-1, keepdims=True)
    n = n / np.where(l1 > 0, l1, 1.0)   # (0, 0, 0) packs as 0, which unpacks as +z
    x, y, z = n[..., 0], n[..., 1], n[..., 2]
    sign_x, sign_y = np.where(x >= 0, 1.0, -1.0), np.where(y >= 0, 1.0, -1.0)
    x, y = np.where(z < 0, (1 - np.abs(y)) * sign_x, x), np.where(z < 0, (1 - np.abs(x)) * sign_y, y)
    qx, qy = (np.rint(np.clip(c, -1, 1) * 32767).astype(np.int32) for c in (x, y))
    return ((qx & 0xFFFF) | (qy << 16)).astype(np.int32)


def unpack_normals(packed):
    """The unit vectors (..., 3) of pack_normals's int32 (...), as the kernel decodes them."""
    packed = np.asarray(packed, np.int32)
    x = ((packed << 16) >> 16).astype(np.float32) * np.float32(1 / 32767)
    y = (packed >> 16).astype(np.float32) * np.float32(1 / 32767)
    z = 1 - np.abs(x) - np.abs(y)
    t = np.maximum(-z, 0)
    n = np.stack([x - np.where(x >= 0, t, -t), y - np.where(y >= 0, t, -t), z], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def pack_media(interior, exterior):
    """TriangleInfo.w: the media inside (behind the front face) and outside, each + 1 (0 = none)."""
    return (interior + 1) | ((exterior + 1) << 16)


# Entries per energy-compensation table of a rough specular material (kernels/materials/energy.h);
# the Material field albedo_tables holds the offset of the material's tables, -1 for none.
ALBEDO_TABLE_SIZE = 64

# The rough coat of plastic (kernels/materials/plastic_coat.h): a row of its tables holds the
# coat's external transmittance at COAT_TABLE_SIZE values of mu = cos(theta), spaced evenly in
# [0, 1] (Mitsuba's MI_ROUGH_TRANSMITTANCE_RES), then its internal reflectance; one row per alpha,
# rows evenly spaced in sqrt(alpha) over a textured alpha's range, at most COAT_SQRT_ALPHA_STEP
# apart (docs/materials-plastic.md measures the interpolation's error).
COAT_TABLE_SIZE = 64
COAT_SQRT_ALPHA_STEP = 1 / 32

# Ray marching's step (kernels/media/raymarch.h): at step 1 a step spans at most one voxel and
# at most MARCH_STEP_OPTICAL_DEPTH of majorant optical depth; the refinement by optical depth stops
# at MARCH_MAX_STEPS_PER_VOXEL steps per voxel (the host reports media that reach it).
MARCH_STEP_OPTICAL_DEPTH = 0.5
MARCH_MAX_STEPS_PER_VOXEL = 64


def c_constants():
    """The enumerations and sizes above as C #define lines."""
    lines = []
    for prefix, table in (("MATERIAL", MATERIAL_KINDS), ("MICROFACET", MICROFACET_DISTRIBUTIONS),
                          ("MASKING", MASKINGS), ("EMITTER", EMITTER_KINDS),
                          ("ENVIRONMENT", ENVIRONMENT_MODES), ("ENV_LOOKUP", ENVIRONMENT_LOOKUPS), ("MEDIUM", MEDIUM_KINDS),
                          ("VOLUME", VOLUME_METHODS), ("SAMPLER", SAMPLERS), ("TEXTURE", TEXTURE_KINDS),
                          ("TEXEL", TEXEL_ENCODINGS), ("FILTER", TEXTURE_FILTERS), ("WRAP", TEXTURE_WRAPS),
                          ("PIXEL_FILTER", PIXEL_FILTERS), ("HIDE", HIDDEN_FROM_CAMERA)):
        lines += [f"#define {prefix}_{name.upper()} {value}" for name, value in table.items()]
    lines.append(f"#define ALBEDO_TABLE_SIZE {ALBEDO_TABLE_SIZE}")
    lines.append(f"#define COAT_TABLE_SIZE {COAT_TABLE_SIZE}")
    lines.append(f"#define MATERIAL_SLOTS {MATERIAL_SLOTS}")
    lines.append(f"#define FILTER_CELLS {FILTER_CELLS}")
    lines.append(f"#define FILTER_EDGES {FILTER_EDGES}")
    lines.append(f"#define ENV_CDF_BLOCK {ENV_CDF_BLOCK}")
    lines.append(f"#define GUIDE_LOBES {GUIDE_LOBES}")
    lines.append(f"#define MARCH_STEP_OPTICAL_DEPTH {float(MARCH_STEP_OPTICAL_DEPTH)!r}f")
    lines.append(f"#define MARCH_MAX_STEPS_PER_VOXEL {float(MARCH_MAX_STEPS_PER_VOXEL)!r}f")
    return "\n".join(lines) + "\n"
