"""PROTOTYPE (branch light-tracing-prototype, not main): the path tracer without the paths
light -> delta+ -> non-delta -> ... -> camera (built with LIGHT_TRACED_CAUSTICS=1 in the
environment, clrender/device.py) plus light tracing of exactly those (kernels/light_paths.cl),
against the path tracer alone (LIGHT_TRACED_CAUSTICS=0): image means, variance over seeds, times.

    LIGHT_TRACED_CAUSTICS=1 python tools/light_tracing_prototype.py ../shared/real-scenes/bitterli-veach-bidir/scene.xml 128 48
    LIGHT_TRACED_CAUSTICS=0 python tools/light_tracing_prototype.py ../shared/real-scenes/bitterli-veach-bidir/scene.xml 128 48

Known gaps: megakernel only, pinhole camera, untextured emitting triangles, no shading-normal
correction of importance, the border pixels' filter not renormalised, records copied whole to
the host (its LT time is mostly that), no media."""
import os, sys, time, warnings, numpy as np
warnings.simplefilter('ignore')
import pyopencl as cl
import clrender
from clrender.device import build_program
from clrender.render import render_params
MAXC = 8
xml = sys.argv[1]; size = int(sys.argv[2]); seeds = int(sys.argv[3]); spp = 64
lt_on = os.environ.get("LIGHT_TRACED_CAUSTICS", "0") == "1"
scene = clrender.load_scene(xml, {'integrator': 'path', 'resx': str(size), 'resy': str(size)})
r = clrender.Renderer(scene, sampler='sobol', packets=False)
W, H = scene.camera.resolution
program = build_program(r.context, r.features, entry="light_paths.cl")
kernel = cl.Kernel(program, "light_paths")
CHUNK = 1 << 16
records_buf = cl.Buffer(r.context, cl.mem_flags.READ_WRITE, CHUNK * 2 * MAXC * 16)
records = np.empty((CHUNK, MAXC, 2, 4), np.float32)

def light_image(seed):
    params = render_params(scene, r.arrays, 0, 1, scene.render.max_depth, scene.render.rr_depth, seed)
    pbuf = cl.Buffer(r.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=params)
    img = np.zeros((H + 2, W + 2, 3))
    n = W * H * spp
    for first in range(0, n, CHUNK):
        kernel(r.queue, (CHUNK,), None, pbuf, *r._buffers, records_buf, np.int32(first))
        cl.enqueue_copy(r.queue, records, records_buf)
        rec = records.reshape(-1, 2, 4)
        keep = np.any(rec[:, 1, :3] != 0, axis=1)
        rec = rec[keep].astype(np.float64)
        x, y, v = rec[:, 0, 0], rec[:, 0, 1], rec[:, 1, :3]
        i0 = np.floor(x - 0.5).astype(int); j0 = np.floor(y - 0.5).astype(int)
        for di in (0, 1):
            for dj in (0, 1):
                i, j = i0 + di, j0 + dj
                w = np.maximum(0, 1 - np.abs(i + 0.5 - x)) * np.maximum(0, 1 - np.abs(j + 0.5 - y))
                np.add.at(img, (j + 1, i + 1), v * w[:, None])
    return img[1:-1, 1:-1] / spp

r.render(spp=4, seed=99)
imgs, tp, tl, lts = [], [], [], []
for s in range(1, seeds + 1):
    t = time.perf_counter(); pt = r.render(spp=spp, seed=s).image[..., :3].astype(np.float64); tp.append(time.perf_counter() - t)
    if lt_on:
        t = time.perf_counter(); lt = light_image(s); tl.append(time.perf_counter() - t)
        lts.append(lt)
        pt = pt + lt
    imgs.append(pt)
imgs = np.stack(imgs)
np.save(f'/tmp/w/lt_{int(lt_on)}.npy', imgs)
if lts: np.save('/tmp/w/lt_only.npy', np.stack(lts)); L=np.stack(lts); print('LT part mean', L.mean(), 'var', L.var(0,ddof=1).mean(), 'max', L.max())
v = imgs.var(0, ddof=1).mean(-1)
inner = imgs[:, 2:-2, 2:-2]
print('LT' if lt_on else 'PT', 'mean', imgs.mean(), 'inner mean', inner.mean(), 'se', inner.mean(axis=(1,2,3)).std(ddof=1)/np.sqrt(seeds),
      'var', v.mean(), 'pixels var>1', int((v > 1).sum()), 'max', imgs.max(), 'pt s', round(np.median(tp), 3), 'lt s', round(np.median(tl), 3) if tl else 0)
