"""Density grids of heterogeneous media: files, procedural generators, validation, majorants.

A grid is a dense float32 array of shape (nz, ny, nx): x varies fastest in memory, as in
Mitsuba's .vol files, so `density[z, y, x]`. It fills the unit cube [0, 1]^3 of its own space
(placed in the world by the medium's transform); sample (x, y, z) sits at the voxel centre
((x + 0.5) / nx, (y + 0.5) / ny, (z + 0.5) / nz). Between centres the density is trilinear,
between the outermost centres and the faces of the cube it is clamped (so a constant grid is
constant up to the faces), and outside the cube it is 0. kernels/media/grid.h does the same.

The majorant grid holds, per block of `block`^3 voxels, the maximum and minimum of every sample
that the trilinear lookup can reach from inside the block (the block dilated by one sample), so
max >= density >= min everywhere in the block. The kernel's DDA (kernels/media/majorant.h)
walks these blocks: tight majorants where the cloud is thin, empty blocks skipped.
"""
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import limits
from .files import check_regular_file, read_bounded

GRID_SUFFIXES = (".npy", ".npz", ".vol")
MAX_VOXELS = 1 << 28          # 1 GiB of float32: beyond that, use a GPU renderer with sparse grids
MAX_PROCEDURAL_VOXELS = 1 << 24   # 256^3: the generators need up to ~100 bytes per voxel
DEFAULT_BLOCK = 8             # majorant block edge in voxels


@dataclass
class DensityGrid:
    density: np.ndarray        # (nz, ny, nx) float32, finite, >= 0
    to_world: np.ndarray       # 4x4 affine: the unit cube [0, 1]^3 -> world
    block: int = DEFAULT_BLOCK
    source: str = ""           # where it came from (file name or generator), for `clrender info`

    @property
    def resolution(self):
        """(nx, ny, nz)."""
        nz, ny, nx = self.density.shape
        return nx, ny, nz

    def world_to_voxel(self):
        """3x4 affine matrix: world point -> voxel coordinates in [0, nx] x [0, ny] x [0, nz]."""
        to_voxel = np.diag([*self.resolution, 1.0]) @ np.linalg.inv(self.to_world)
        return to_voxel[:3]

    def world_bounds(self):
        """(min, max) corners of the grid's box in the world (the box of its 8 corners)."""
        corners = np.array([[x, y, z, 1.0] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
        world = corners @ self.to_world.T
        return world[:, :3].min(axis=0), world[:, :3].max(axis=0)

    def majorants(self):
        """(max, min) per majorant block, each of shape (mz, my, mx)."""
        return block_bounds(self.density, self.block)

    def longest_voxel_step(self):
        """The longest world length of a unit step in voxel space (any direction)."""
        voxel_to_world = self.to_world[:3, :3] / np.asarray(self.resolution, dtype=float)
        return float(np.linalg.norm(voxel_to_world, ord=2))


# --------------------------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------------------------
def check_density(array):
    """The problem with `array` as a density grid, or None when it is valid."""
    array = np.asarray(array)
    if array.ndim != 3:
        return f"must be a 3D array (z, y, x), got shape {array.shape}"
    return _check_values(array)


def _check_values(array):
    """The problem with the values of a grid (any shape), or None."""
    if array.size == 0:
        return f"must not be empty, got shape {array.shape}"
    if array.size > MAX_VOXELS:
        return f"has {array.size} voxels, more than the limit of {MAX_VOXELS}"
    if not np.issubdtype(array.dtype, np.number) or np.iscomplexobj(array):
        return f"must hold real numbers, got dtype {array.dtype}"
    with np.errstate(over="ignore", invalid="ignore"):   # beyond float32: caught just below
        values = array.astype(np.float32)
    if not (np.all(np.isfinite(values)) and np.all(values >= 0)):
        return "must be finite and non-negative"
    return None


# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------
def load_density_file(path):
    """A density array from .npy, .npz (key 'density', or its only array) or Mitsuba .vol.

    Raises ValueError with a message meant for the user."""
    path = Path(path)
    if path.suffix.lower() == ".vol":
        return read_vol(path)[0]
    return _load_numpy(path, "density")


def _load_numpy(path, name):
    """The array of an .npy file, or of an .npz file the one named `name` (or its only one)."""
    check_regular_file(path, "grid file", limits.MAX_GRID_FILE_BYTES)
    suffix = path.suffix.lower()
    if suffix == ".npy":
        with open(path, "rb") as f:
            _check_npy_header(f)
        return np.load(path, allow_pickle=False)
    if suffix == ".npz":
        with np.load(path, allow_pickle=False) as archive:
            keys = list(archive.keys())
            if name in keys:
                key = name
            elif len(keys) == 1:
                key = keys[0]
            else:
                raise ValueError(f"holds {len(keys)} arrays ({', '.join(keys)}) and none named {name!r}")
            with archive.zip.open(f"{key}.npy") as f:
                _check_npy_header(f)
            return archive[key]
    raise ValueError(f"unsupported grid format {suffix!r}; valid: {', '.join(GRID_SUFFIXES)}")


def load_albedo_file(path):
    """An albedo grid (nz, ny, nx, channels), channels 1 or 3, from .npy, .npz (key 'albedo', or
    its only array) or a .vol of 1 or 3 channels; a 3D array is one channel. Raises ValueError
    with a message meant for the user."""
    path = Path(path)
    values = read_vol(path, channels_allowed=(1, 3))[0] if path.suffix.lower() == ".vol" else _load_numpy(path, "albedo")
    values = np.asarray(values)
    if values.ndim == 3:
        values = values[..., None]
    if values.ndim != 4 or values.shape[3] not in (1, 3):
        raise ValueError(f"must be a (z, y, x) or (z, y, x, 3) array, got shape {values.shape}")
    problem = _check_values(values)
    if problem:
        raise ValueError(problem)
    values = values.astype(np.float32)
    if np.any(values > 1):
        raise ValueError(f"albedos must be in [0, 1], the largest is {values.max():g}")
    return values


def _check_npy_header(f):
    """Refuse an .npy array whose header announces more than MAX_VOXELS values before numpy
    allocates them (an .npz member is allocated whole before it is read)."""
    version = np.lib.format.read_magic(f)
    shape, _, dtype = (np.lib.format.read_array_header_1_0(f) if version == (1, 0)
                       else np.lib.format.read_array_header_2_0(f))
    count = int(np.prod(shape, dtype=object))
    if count > MAX_VOXELS:
        raise ValueError(f"holds {count} values (shape {shape}), more than the limit of {MAX_VOXELS}")


_VOL_HEADER = struct.Struct("<3sBiiiii6f")   # magic, version, encoding, x/y/z res, channels, bbox


def read_vol(path, channels_allowed=(1,)):
    """Mitsuba's binary grid: 'VOL', version 3, encoding 1 (float32), xres, yres, zres,
    channels, bounding box (6 floats), then the data with x fastest, then y, z, channels
    interleaved. Returns (values, bbox (2, 3)): values (nz, ny, nx) float32 for one channel,
    (nz, ny, nx, channels) for more. Densities have one channel, albedos one or three."""
    data = read_bounded(path, "grid file", limits.MAX_GRID_FILE_BYTES)
    if len(data) < _VOL_HEADER.size:
        raise ValueError(f"too short for a .vol header ({len(data)} bytes)")
    magic, version, encoding, nx, ny, nz, channels, *bbox = _VOL_HEADER.unpack_from(data)
    if magic != b"VOL":
        raise ValueError(f"not a Mitsuba .vol file (magic {magic!r}, expected b'VOL')")
    if version != 3:
        raise ValueError(f"unsupported .vol version {version} (expected 3)")
    if encoding != 1:
        raise ValueError(f"unsupported .vol encoding {encoding} (only 1 = float32)")
    if channels not in channels_allowed:
        raise ValueError(f"this .vol has {channels} channels, expected {' or '.join(map(str, channels_allowed))}")
    if min(nx, ny, nz) < 1:
        raise ValueError(f"invalid .vol resolution {nx} x {ny} x {nz}")
    count = nx * ny * nz * channels
    if count > MAX_VOXELS:
        raise ValueError(f"{nx} x {ny} x {nz} x {channels} values, more than the limit of {MAX_VOXELS}")
    expected = _VOL_HEADER.size + 4 * count
    if len(data) != expected:
        raise ValueError(f"size {len(data)} bytes does not match {nx} x {ny} x {nz} x {channels} floats "
                         f"({expected} bytes)")
    values = np.frombuffer(data, dtype="<f4", count=count, offset=_VOL_HEADER.size)
    shape = (nz, ny, nx) if channels == 1 else (nz, ny, nx, channels)
    return values.reshape(shape).astype(np.float32), np.array(bbox, dtype=float).reshape(2, 3)


def write_vol(path, values, bbox=((0, 0, 0), (1, 1, 1))):
    """Write (nz, ny, nx) values, or (nz, ny, nx, channels), as a Mitsuba .vol (version 3, float32)."""
    values = np.ascontiguousarray(values, dtype="<f4")
    nz, ny, nx = values.shape[:3]
    channels = values.shape[3] if values.ndim == 4 else 1
    header = _VOL_HEADER.pack(b"VOL", 3, 1, nx, ny, nz, channels, *np.asarray(bbox, float).ravel())
    Path(path).write_bytes(header + values.tobytes())


# --------------------------------------------------------------------------------------------
# Procedural grids (numpy only, fixed seeds): for tests and example scenes
# --------------------------------------------------------------------------------------------
def voxel_centres(resolution):
    """Unit-cube coordinates of the voxel centres: three (nz, ny, nx) arrays x, y, z."""
    nx, ny, nz = resolution
    z, y, x = np.meshgrid((np.arange(nz) + 0.5) / nz, (np.arange(ny) + 0.5) / ny,
                          (np.arange(nx) + 0.5) / nx, indexing="ij")
    return x, y, z


def constant(resolution, value=1.0):
    nx, ny, nz = resolution
    return np.full((nz, ny, nx), value, np.float32)


def gradient(resolution, axis=0, low=0.0, high=1.0):
    """Linear in one unit-cube coordinate: low + (high - low) * c at the voxel centres, so the
    trilinear density is exactly linear between the outermost centres along that axis."""
    coordinate = voxel_centres(resolution)[axis]
    return (low + (high - low) * coordinate).astype(np.float32)


def sphere_falloff(resolution):
    """1 at the centre of the cube, falling linearly to 0 at distance 0.5 (the inscribed ball)."""
    x, y, z = voxel_centres(resolution)
    r = np.sqrt((x - 0.5) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2)
    return np.clip(1.0 - r / 0.5, 0.0, None).astype(np.float32)


def value_noise(resolution, cells, rng):
    """Smooth value noise in [0, 1]: random values on a lattice of cells^3 over the cube,
    interpolated with smoothstep weights (separable, one axis at a time)."""
    lattice = rng.random((cells + 1,) * 3)
    for axis, n in zip((2, 1, 0), resolution):       # x is the last array axis
        position = (np.arange(n) + 0.5) / n * cells
        index = np.minimum(position.astype(int), cells - 1)
        f = position - index
        f = f * f * (3 - 2 * f)
        shape = [1, 1, 1]
        shape[axis] = n
        f = f.reshape(shape)
        lattice = (np.take(lattice, index, axis=axis) * (1 - f) + np.take(lattice, index + 1, axis=axis) * f)
    return lattice


def fbm(resolution, rng, base_cells=3, octaves=4):
    """Fractal sum of value noise, normalised to [0, 1]."""
    total = np.zeros(tuple(reversed(resolution)))
    amplitude, norm = 1.0, 0.0
    for octave in range(octaves):
        total += amplitude * value_noise(resolution, base_cells * 2 ** octave, rng)
        norm += amplitude
        amplitude *= 0.5
    return total / norm


def noise_cloud(resolution, seed=0):
    """A cumulus-like cloud: a union of a dozen soft blobs (a flat base, billows on top) whose
    surface is eroded by fractal noise; dense core (about 1), wispy edges, empty corners."""
    rng = np.random.default_rng(seed)
    x, y, z = voxel_centres(resolution)
    shape = np.full_like(x, -1.0)
    for _ in range(12):
        cx, cz = rng.uniform(0.3, 0.7, 2)
        cy = rng.uniform(0.35, 0.55)
        radius = rng.uniform(0.12, 0.22)
        r = np.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / radius
        shape = np.maximum(shape, 1.0 - r)
    shape -= np.clip((0.3 - y) / 0.08, 0, None)       # a flat base
    noise = fbm(resolution, rng, base_cells=4, octaves=4)
    density = 3.0 * (shape + 0.35 * (noise - 0.5))
    return np.clip(density, 0.0, 1.0).astype(np.float32)


def smoke_plume(resolution, seed=0):
    """A rising plume: a column from the bottom centre that widens, drifts and thins with
    height, its edges broken up by noise."""
    rng = np.random.default_rng(seed)
    x, y, z = voxel_centres(resolution)
    phase = rng.random(4) * 2 * np.pi
    cx = 0.5 + 0.12 * y * np.sin(7.0 * y + phase[0]) + 0.05 * np.sin(13.0 * y + phase[1])
    cz = 0.5 + 0.12 * y * np.cos(6.0 * y + phase[2]) + 0.05 * np.sin(11.0 * y + phase[3])
    width = 0.05 + 0.28 * y
    radial = np.sqrt((x - cx) ** 2 + (z - cz) ** 2) / width
    noise = fbm(resolution, rng, base_cells=4, octaves=4)
    column = np.exp(-(radial ** 2) * (1.0 + 1.5 * noise))
    height = np.clip(y / 0.05, 0, 1) * np.clip((1.0 - y) / 0.25, 0, 1) * (1.0 - 0.6 * y)
    density = column * height * (0.6 + 0.8 * noise)
    return np.clip(density, 0.0, None).astype(np.float32)


# name -> (generator, {option: (default, kind, low, high)}); options besides resolution and seed.
PROCEDURAL = {
    "noise_cloud": (noise_cloud, {"seed": (0, int, 0, 2**32 - 1)}),
    "smoke_plume": (smoke_plume, {"seed": (0, int, 0, 2**32 - 1)}),
    "sphere_falloff": (sphere_falloff, {}),
    "constant": (constant, {"value": (1.0, float, 0, None)}),
    "gradient": (gradient, {"axis": (0, int, 0, 2), "low": (0.0, float, 0, None),
                            "high": (1.0, float, 0, None)}),
}


def procedural(name, resolution, **options):
    generator, _ = PROCEDURAL[name]
    return generator(tuple(resolution), **options)


# --------------------------------------------------------------------------------------------
# Majorant grid and the reference lookup
# --------------------------------------------------------------------------------------------
def block_bounds(density, block):
    """Per block of `block` voxels per axis: (max, min) of the samples that trilinear lookups
    inside the block reach. A point in block b along an axis (voxel coordinates in
    [b * block, (b + 1) * block)) interpolates samples b * block - 1 .. (b + 1) * block, clamped
    to the grid. Separable: the max over a box is the max over each axis in turn."""
    high = np.asarray(density, np.float32)
    low = high
    for axis in range(3):
        n = high.shape[axis]
        blocks = -(-n // block)
        ranges = [(max(b * block - 1, 0), min((b + 1) * block, n - 1) + 1) for b in range(blocks)]
        high = np.stack([np.take(high, range(a, e), axis=axis).max(axis=axis) for a, e in ranges], axis=axis)
        low = np.stack([np.take(low, range(a, e), axis=axis).min(axis=axis) for a, e in ranges], axis=axis)
    return high, low


def trilinear(density, points):
    """Reference lookup: the density at unit-cube points (N, 3), as the kernel computes it."""
    density = np.asarray(density, np.float64)
    nz, ny, nx = density.shape
    points = np.asarray(points, np.float64)
    inside = np.all((points >= 0) & (points <= 1), axis=1)
    voxel = points * [nx, ny, nz] - 0.5
    base = np.floor(voxel).astype(int)
    f = voxel - base
    result = np.zeros(len(points))
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                ix = np.clip(base[:, 0] + dx, 0, nx - 1)
                iy = np.clip(base[:, 1] + dy, 0, ny - 1)
                iz = np.clip(base[:, 2] + dz, 0, nz - 1)
                w = ((f[:, 0] if dx else 1 - f[:, 0]) * (f[:, 1] if dy else 1 - f[:, 1])
                     * (f[:, 2] if dz else 1 - f[:, 2]))
                result += w * density[iz, iy, ix]
    return np.where(inside, result, 0.0)
