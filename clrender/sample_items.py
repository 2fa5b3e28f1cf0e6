"""Sample items: a render pass with one work-item per (pixel, sample of the pass) instead of one
per pixel taking the pass's samples in turn (kernels/integrator.cl).

A GPU keeps hundreds of thousands of threads resident (an H200: 132 multiprocessors x 2,048); an
image of 128 x 96 pixels gives one work-item per pixel 12,288 of them, so a launch lasts as long
as its slowest pixel's paths while most of the device idles (docs/performance.md). Over (pixel,
sample) the same launch has 64 times the work-items at 64 samples. Each writes its sample as a
record (kernels/splat.h: the splatting record, or its radiance alone when the film does not
splat), and `sum_samples` (kernels/splat.cl) adds each pixel's records to its accumulator in
sample order: the sums are the bits of the per-pixel loop. A render that accumulates the
sample-level AOVs (kernels/aovs.h) writes each sample's AOVs as a record too (layout.AOV_SUMS),
and sum_samples adds them and the colour's deviations in the same order. On an H100 1.2-3.3
times faster on the real scenes at 128 pixels; blocks of 4 or 16 samples per work-item were slower
(docs/performance.md). CPUs keep one work-item per pixel (or packet), whose loop already fills
their few cores."""
import pyopencl as cl

from .device import build_program
from .features import gather_features

# sum_samples' work-group size on CPU devices (the kernel skips work-items beyond the tile).
CPU_LOCAL_SIZE = (8, 1)


def wanted(device, features):
    """Whether a render pass on `device` of a kernel built with `features` takes sample items by
    default: on GPUs and other non-CPU devices, for the megakernel (not packets, LANES 8)."""
    return not device.type & cl.device_type.CPU and features["LANES"] == 1


class SampleSums:
    """The sum_samples kernel of one device (kernels/splat.cl, the program of splatting's gather);
    `sample_aovs`: the one that also adds the sample-level AOVs' records to their sums."""

    def __init__(self, context, packets=False, sample_aovs=False):
        program = build_program(context, gather_features(packets, sample_aovs), entry="splat.cl")
        self.kernel = cl.Kernel(program, "sum_samples")
        self.local_size = CPU_LOCAL_SIZE if context.devices[0].type & cl.device_type.CPU else None

    def __call__(self, queue, traced, params_buffer, records, accumulator, *aov_buffers):
        """Add the records of the pass of `params_buffer` to the sums `accumulator` of the pixels
        `traced`; `aov_buffers` (sample_aovs): the pass's AOV records and the AOV sums."""
        size = (traced[2], traced[3])
        if self.local_size:
            size = tuple(-(-n // m) * m for n, m in zip(size, self.local_size))
        self.kernel(queue, size, self.local_size, params_buffer, records, accumulator, *aov_buffers)
