"""Copies of the real scenes (../shared/real-scenes) with a small film, for renders in tests: the
scene's folder is mirrored into a temporary one, its XML files copied (and their film sizes
edited), every other file and every folder without XML linked, so that relative paths, includes
and `<path>` elements resolve as in the original and nothing large is copied."""
import os
import re


def mirror(source, target):
    """`source` mirrored into `target`: XML files copied, folders holding XML made, the rest linked."""
    target.mkdir(parents=True, exist_ok=True)
    for entry in sorted(source.iterdir()):
        if entry.is_dir() and not any(entry.rglob("*.xml")):
            os.symlink(entry, target / entry.name)
        elif entry.is_dir():
            mirror(entry, target / entry.name)
        elif entry.suffix == ".xml":
            (target / entry.name).write_text(entry.read_text())
        else:
            os.symlink(entry, target / entry.name)


def film_sized(text, width, height):
    """The XML `text` with every integer width and height (the film's) set to `width` x `height`."""
    for name, value in (("width", width), ("height", height)):
        text = re.sub(rf'(<integer\s+name="{name}"\s+value=")[^"]*(")', rf"\g<1>{value}\g<2>", text)
    return text


def small_copy(scene_folder, relative, target, width, height, edit=lambda text: text):
    """The scene file `relative` of `scene_folder`, in a mirror under `target` whose films are
    `width` x `height`, and whose XML texts are passed through `edit`."""
    mirror(scene_folder, target)
    for xml in target.rglob("*.xml"):
        if not xml.is_symlink():
            xml.write_text(edit(film_sized(xml.read_text(), width, height)))
    return target / relative
