"""tools/profile_split.py: perf's report lines become samples per DSO and symbol, and each
renderer's samples split into traversal and the rest of its kernels (the lines below are perf
3's output for a clrender process on PoCL and a Mitsuba llvm_ad_rgb one)."""
import importlib.util
from pathlib import Path

spec = importlib.util.spec_from_file_location("profile_split",
                                              Path(__file__).parent.parent / "tools" / "profile_split.py")
profile_split = importlib.util.module_from_spec(spec)
spec.loader.exec_module(profile_split)

CLRENDER_REPORT = """\
# Samples: 21K of event 'cpu-clock:ppp'
#
         4380  render_pass.so                                     [.] traverse_bvh
         1322  render_pass.so                                     [.] trace_paths
          895  render_pass.so                                     [.] traverse_bvh_packet
          345  render_pass.so                                     [.] closest_hits
          233  render_pass.so                                     [.] intersect_sphere_leaf_lanes
           97  gather_splats.so                                   [.] _pocl_kernel_gather_splats_workgroup
           20  guide_photons.so                                   [.] traverse_bvh
          230  libscipy_openblas64_-32a4b2a6.so                   [.] blas_thread_server
           66  libpython3.11.so.1.0                               [.] _PyEval_EvalFrameDefault
           68  [kernel.kallsyms]                                  [k] exc_page_fault
"""

MITSUBA_REPORT = """\
         3437  libembree3.so                               [.] embree::avx512::BVHNIntersectorKHybrid<8, 16, 1, false, embree::avx512::ArrayIntersectorK_1<16, embree::avx512::TriangleMIntersectorKMoeller<4, 16, false> >, true>::intersect
         2152  libembree3.so                               [.] embree::avx512::BVHNIntersectorKHybrid<8, 16, 1, false, embree::avx512::ArrayIntersectorK_1<16, embree::avx512::TriangleMIntersectorKMoeller<4, 16, false> >, true>::occluded
           84  [JIT] tid 17645                             [.] 0x00007fb3fc01facd
           83  [JIT] tid 17645                             [.] 0x00007fb3fc01fa23
          107  libscipy_openblas64_-32a4b2a6.so            [.] blas_thread_server
           40  libLLVM-19.so                               [.] llvm::SelectionDAG::Combine
"""


def test_report_lines_become_samples_per_library_and_function():
    counts = profile_split.report_counts(CLRENDER_REPORT)
    assert counts[("render_pass.so", "traverse_bvh")] == 4380
    assert counts[("guide_photons.so", "traverse_bvh")] == 20
    assert counts[("[kernel.kallsyms]", "exc_page_fault")] == 68
    assert sum(counts.values()) == 4380 + 1322 + 895 + 345 + 233 + 97 + 20 + 230 + 66 + 68
    # A library whose name holds spaces (Dr.Jit's code) stays one name.
    assert profile_split.report_counts(MITSUBA_REPORT)[("[JIT] tid 17645", "0x00007fb3fc01facd")] == 84


def test_clrender_splits_its_kernels_walks_from_the_rest_of_its_kernels():
    traversal, rest = profile_split.split_clrender(profile_split.report_counts(CLRENDER_REPORT))
    assert traversal == 4380 + 895 + 345 + 233 + 20
    assert rest == 1322 + 97   # system libraries (BLAS, Python, the kernel) are neither


def test_mitsuba_splits_embree_from_its_jit_kernel():
    traversal, rest = profile_split.split_mitsuba(profile_split.report_counts(MITSUBA_REPORT))
    assert traversal == 3437 + 2152
    assert rest == 84 + 83   # LLVM's compilation is neither
