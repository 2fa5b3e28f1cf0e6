"""The kernel's BVH traversal finds exactly the hits of a brute-force numpy intersector."""
import numpy as np
import pyopencl as cl
import pytest

import clrender
from clrender import layout, wide_bvh
from clrender.triangle_blocks import triangle_blocks
from clrender.bvh import build_bvh, intersect_brute_force
from conftest import build_test_kernels, camera


def triangle_soup(rng, count, spread=4.0, size=0.6):
    v0 = rng.uniform(-spread, spread, (count, 3))
    return v0, v0 + rng.normal(0, size, (count, 3)), v0 + rng.normal(0, size, (count, 3))


def random_rays(rng, count):
    origins = rng.uniform(-8, 8, (count, 3))
    targets = rng.uniform(-3, 3, (count, 3))
    directions = targets - origins
    return origins, directions / np.linalg.norm(directions, axis=1, keepdims=True)


def trace_on_device(context, queue, v0, v1, v2, origins, directions):
    tree = build_bvh(v0, v1, v2)
    nodes, _ = wide_bvh.collapse(tree)
    order = tree.prim_order
    nodes, blocks = triangle_blocks(nodes, v0, v1, v2, order)
    spheres = np.zeros(1, layout.SPHERE)
    rays = [np.zeros((len(origins), 4), np.float32) for _ in range(2)]
    rays[0][:, :3], rays[1][:, :3] = origins, directions
    mf = cl.mem_flags
    inputs = [cl.Buffer(context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
              for x in (nodes, blocks, spheres, *rays)]
    t = np.empty(len(origins), np.float32)
    slot = np.empty(len(origins), np.int32)
    any_hit = np.empty(len(origins), np.int32)
    outputs = [cl.Buffer(context, mf.WRITE_ONLY, x.nbytes) for x in (t, slot, any_hit)]
    cl.Kernel(build_test_kernels(context), "trace_rays")(queue, (len(origins),), None, *inputs, *outputs)
    for host, buffer in zip((t, slot, any_hit), outputs):
        cl.enqueue_copy(queue, host, buffer)
    triangle = np.append(order, -1)[slot]  # back to input indices; slot -1 (miss) stays -1
    return t, triangle, any_hit.astype(bool)


@pytest.mark.parametrize("count,seed", [(0, 1), (1, 2), (3, 3), (100, 4), (5000, 5)])
def test_kernel_hits_equal_brute_force(context, queue, count, seed):
    rng = np.random.default_rng(seed)
    v0, v1, v2 = triangle_soup(rng, count)
    origins, directions = random_rays(rng, 4000)
    t, triangle, any_hit = trace_on_device(context, queue, v0, v1, v2, origins, directions)
    if count:
        ref_t, ref_triangle = intersect_brute_force(v0, v1, v2, origins, directions)
    else:
        ref_t, ref_triangle = np.full(len(origins), np.inf), np.full(len(origins), -1)
    hit = ref_triangle >= 0
    assert np.array_equal(triangle >= 0, hit)
    assert np.array_equal(any_hit, hit)
    np.testing.assert_allclose(t[hit], ref_t[hit], rtol=1e-4)
    # Ties (two triangles at the same distance within float32) may resolve either way.
    differs = triangle != ref_triangle
    assert np.all(np.abs(t[differs] - ref_t[differs]) <= 1e-4 * ref_t[differs])
    if count >= 100:
        assert hit.mean() > 0.2  # the test rays do hit things


def assert_hits_match_brute_force(context, queue, v0, v1, v2, origins, directions, rtol):
    """Closest and any hits of the kernel are those of the brute-force intersector, for test rays
    of which at least 30 % hit something."""
    t, triangle, any_hit = trace_on_device(context, queue, v0, v1, v2, origins, directions)
    ref_t, ref_triangle = intersect_brute_force(v0, v1, v2, origins, directions)
    hit = ref_triangle >= 0
    assert hit.mean() > 0.3
    assert np.array_equal(triangle >= 0, hit) and np.array_equal(any_hit, hit)
    np.testing.assert_allclose(t[hit], ref_t[hit], rtol=rtol)


@pytest.mark.parametrize("offset,scale", [(1e4, 1e-3), (-2e5, 1.0), (3e3, 1e4)])
def test_kernel_hits_equal_brute_force_far_from_the_origin(context, queue, offset, scale):
    """Far from the world origin, and at small and large scales, the slab test's rounding margins
    (kernels/bvh.h) keep every box a ray crosses: rays start among the triangles, where the
    distances to boxes are small against the coordinates."""
    rng = np.random.default_rng(11)
    v0, v1, v2 = (offset + scale * corner for corner in triangle_soup(rng, 1500))
    v0, v1, v2 = (corner.astype(np.float32).astype(np.float64) for corner in (v0, v1, v2))
    origins, directions = random_rays(rng, 3000)
    origins = (offset + scale * origins / 2).astype(np.float32).astype(np.float64)
    assert_hits_match_brute_force(context, queue, v0, v1, v2, origins, directions, rtol=1e-3)


def test_axis_parallel_rays_find_their_hits(context, queue):
    """Rays with zero (and negative zero) direction components: an infinite inverse direction
    must not make the slab test lose boxes."""
    rng = np.random.default_rng(9)
    v0, v1, v2 = triangle_soup(rng, 2000)
    axes = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
                     [-0.0, 1, -0.0], [0.0, -0.0, -1], [0.6, 0.8, 0], [0, -0.6, 0.8]], float)
    origins = np.repeat(rng.uniform(-5, 5, (400, 3)), len(axes), axis=0)
    directions = np.tile(axes, (400, 1))
    assert_hits_match_brute_force(context, queue, v0, v1, v2, origins, directions, rtol=1e-4)


def test_tiny_and_empty_scenes_render(device):
    """Scenes whose BVH is a single leaf, or empty, must not read missing nodes or hang."""
    materials = [{"name": "m", "type": "diffuse", "albedo": [0.5, 0.5, 0.5]}]
    lights = [{"type": "environment", "radiance": 1.0}]
    for shapes in ([], [{"type": "rectangle", "material": "m"}]):
        scene = clrender.load_scene_dict({"camera": camera(resolution=(8, 8)), "materials": materials,
                                          "shapes": shapes, "lights": lights})
        result = clrender.Renderer(scene, device).render(spp=2)
        assert result.discarded_samples == 0 and np.all(np.isfinite(result.image))
        assert result.image.max() == 1.0
