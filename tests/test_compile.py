"""Kernel compile checks: every combination of feature defines builds; errors carry the log."""
import pyopencl as cl
import pytest

from clrender import KernelBuildError, device as device_module
from clrender.device import build_program, kernel_dir, kernel_source
from clrender.feature_scenes import feature_scene
from clrender.features import all_feature_combinations, describe, scene_features


@pytest.mark.parametrize("features", list(all_feature_combinations()), ids=describe)
def test_every_feature_combination_builds(context, features):
    program = build_program(context, features)
    assert cl.Kernel(program, "render_pass").num_args == 26


def test_test_kernels_build_with_every_environment(context):
    # tests.cl has no AOV kernels; the AOV code it reaches through path.h (grid media) is built
    # with every combination above. Its builds are the slower ones: doubling this loop would add
    # more than the 48 AOVS builds above did (docs/denoising.md, "Cost").
    for features in all_feature_combinations():
        if features["AOVS"] or features["LANES"] > 1:   # the test kernels run one lane
            continue
        assert cl.Kernel(build_program(context, features, entry="tests.cl"), "trace_rays").num_args == 8


def test_light_paths_and_guide_photons_build_wherever_they_may_apply(context):
    # clrender/light_paths.py, clrender/guide.py: no media or toon shading; built at one lane
    # whatever the render's.
    built = set()
    for features in all_feature_combinations():
        if features["MEDIA"] or features["TOON"] or features["GRID_MEDIA"]:
            continue
        features = {**features, "LANES": 1}
        if describe(features) in built:
            continue
        built.add(describe(features))
        assert cl.Kernel(build_program(context, features, entry="light_paths.cl"), "light_paths").num_args == 22
        assert cl.Kernel(build_program(context, features, entry="guide_photons.cl"), "guide_photons").num_args == 25
    assert len(built) >= 8


def test_build_error_carries_the_compiler_log(context, tmp_path, monkeypatch):
    (tmp_path / "broken.cl").write_text('#include "helper.h"\n__kernel void k() { int x = undefined_name; }\n')
    (tmp_path / "helper.h").write_text("// nothing\n")
    monkeypatch.setattr(device_module, "kernel_dir", lambda: tmp_path)
    with pytest.raises(KernelBuildError) as error:
        build_program(context, {}, entry="broken.cl")
    assert "undefined_name" in str(error.value)
    assert "broken.cl" in str(error.value)  # #line markers name the file, not the assembled text


def test_every_combination_has_a_scene_that_needs_exactly_it():
    # The scenes the Oclgrind tests and `clrender info --kernel` run (clrender/feature_scenes.py).
    for features in all_feature_combinations():
        scene, method = feature_scene(features)
        # AOVS is a request of the render, not of the scene (the Oclgrind worker asks for them).
        assert scene_features(scene, method, sample_aovs=features["AOVS"],
                              packets=features["LANES"] > 1) == features, describe(features)


def test_every_entry_point_is_declared_kernel():
    # KERNEL (kernels/portability.h) carries the work-around for Intel's implicit vectoriser
    # (docs/portability.md); a plain __kernel would bring the miscompilation back.
    root = kernel_dir()
    files = [p for p in root.rglob("*") if p.suffix in (".h", ".cl") and p.name != "portability.h"]
    assert files
    for path in files:
        text = path.read_text()
        assert "__kernel" not in text, f"{path.relative_to(root)}: declare entry points KERNEL"
    entry_points = sum(path.read_text().count("\nKERNEL void ") for path in files)
    assert entry_points >= 16


def test_kernel_source_is_fully_expanded():
    source = kernel_source()
    assert "#include" not in source  # its hash, the cache key, covers every header
    assert '#line 1 "materials/diffuse.h"' in source


def test_no_include_is_conditional():
    # The assembler expands each file once, at its first #include: a header first included inside
    # an #if that is false would vanish for every later includer. So headers are included
    # unconditionally and guard their own contents with feature #ifs.
    offenders = []
    for path in sorted(kernel_dir().rglob("*.h")) + sorted(kernel_dir().rglob("*.cl")):
        depth, guarded = 0, path.suffix == ".h"   # a header's outermost #ifndef is its include guard
        for number, line in enumerate(path.read_text().splitlines(), start=1):
            directive = line.strip()
            if directive.startswith(("#if", "#ifdef", "#ifndef")):
                depth += 1
            elif directive.startswith("#endif"):
                depth -= 1
            elif directive.startswith("#include") and depth > (1 if guarded else 0):
                offenders.append(f"{path.name}:{number}")
    assert offenders == []
