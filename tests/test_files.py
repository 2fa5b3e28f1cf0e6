"""clrender/files.py: paths resolved as Path.resolve does, each folder once within a scene's load."""
import os

import pytest

from clrender import files


@pytest.fixture
def tree(tmp_path):
    """real/ with a file and a folder link to it, a file link, and a link to a missing file."""
    (tmp_path / "real").mkdir()
    (tmp_path / "real" / "mesh.obj").write_text("v 0 0 0\n")
    os.symlink(tmp_path / "real", tmp_path / "linked")
    os.symlink(tmp_path / "real" / "mesh.obj", tmp_path / "real" / "alias.obj")
    os.symlink(tmp_path / "nowhere.obj", tmp_path / "real" / "dangling.obj")
    # A mirror of real/ as tools/real_scenes.py makes one, and links relative, chained, to a
    # folder link's path, to a folder, and in a loop.
    (tmp_path / "mirror").mkdir()
    os.symlink(tmp_path / "real" / "mesh.obj", tmp_path / "mirror" / "mesh.obj")
    os.symlink("../real/mesh.obj", tmp_path / "mirror" / "relative.obj")
    os.symlink("relative.obj", tmp_path / "mirror" / "chained.obj")
    os.symlink(tmp_path / "linked" / "alias.obj", tmp_path / "mirror" / "through_folder_link.obj")
    os.symlink("../linked/..", tmp_path / "mirror" / "up.obj")
    os.symlink("loop_b.obj", tmp_path / "mirror" / "loop_a.obj")
    os.symlink("loop_a.obj", tmp_path / "mirror" / "loop_b.obj")
    return tmp_path


NAMES = ["real/mesh.obj", "linked/mesh.obj", "real/alias.obj", "linked/alias.obj", "real/dangling.obj",
         "linked/../real/mesh.obj", "real/missing.obj", "real/..", "linked/.", "real/sub/../mesh.obj",
         "mirror/mesh.obj", "mirror/relative.obj", "mirror/chained.obj", "mirror/through_folder_link.obj",
         "mirror/up.obj"]


@pytest.mark.parametrize("name", NAMES)
def test_resolved_paths_are_those_of_path_resolve(tree, name):
    path = tree / name
    assert files.resolved(path) == path.resolve()
    with files.resolving_folders_once():
        assert files.resolved(path) == path.resolve()
        assert files.resolved(path) == path.resolve()   # the second time from the folder cache


def test_a_loop_of_links_ends_where_realpath_ends_it(tree):
    # (Path.resolve raises on a loop; the reader's not_a_file then reports the path.)
    path = tree / "mirror" / "loop_a.obj"
    with files.resolving_folders_once():
        assert str(files.resolved(path)) == os.path.realpath(path)


def test_folders_are_resolved_again_in_the_next_load(tree):
    # A folder link changed between two loads is followed to its new target.
    os.makedirs(tree / "other")
    (tree / "other" / "mesh.obj").write_text("v 1 1 1\n")
    with files.resolving_folders_once():
        assert files.resolved(tree / "linked" / "mesh.obj") == tree.resolve() / "real" / "mesh.obj"
    os.unlink(tree / "linked")
    os.symlink(tree / "other", tree / "linked")
    with files.resolving_folders_once():
        assert files.resolved(tree / "linked" / "mesh.obj") == tree.resolve() / "other" / "mesh.obj"
