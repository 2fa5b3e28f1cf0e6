"""Host arrays that a CPU device's kernels read in place (render.Renderer._upload passes them
with CL_MEM_USE_HOST_PTR: no copy, and a large scene is not in memory twice). OpenCL gives
kernels buffers aligned to the device's base address alignment, and compilers use aligned
vector loads on them (a float8 field of a BVH node 16 bytes off a 32-byte boundary crashes
PoCL's kernels), while numpy aligns its allocations to 16 bytes only: the large scene arrays are
allocated here, on page boundaries, and any other array is copied once (`aligned`)."""
import numpy as np

# A page: at least every device's base address alignment (PoCL asks 128 bytes, Intel's runtime
# 4096 for reading in place).
ALIGNMENT = 4096


def empty(shape, dtype):
    """np.empty(shape, dtype), its data on an ALIGNMENT boundary."""
    return _allocate(np.empty, shape, dtype)


def zeros(shape, dtype):
    """np.zeros(shape, dtype), its data on an ALIGNMENT boundary."""
    return _allocate(np.zeros, shape, dtype)


def _allocate(allocate, shape, dtype):
    dtype = np.dtype(dtype)
    size = int(np.prod(shape)) * dtype.itemsize
    raw = allocate(size + ALIGNMENT, np.uint8)
    start = -raw.ctypes.data % ALIGNMENT
    return raw[start:start + size].view(dtype).reshape(shape)


def copy(array):
    """A copy of `array`, its data on an ALIGNMENT boundary."""
    out = empty(array.shape, array.dtype)
    out[...] = array
    return out


def aligned(array):
    """`array` itself where it is contiguous and aligned, else an aligned copy."""
    return array if array.flags["C_CONTIGUOUS"] and array.ctypes.data % ALIGNMENT == 0 else copy(array)
