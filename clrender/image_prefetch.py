"""Image files a scene names, decoded on worker threads while the rest of the scene loads.

OpenImageIO decodes without holding Python's lock, so a scene's textures and environment map
decode while its meshes parse (the staircase: 9 JPEG textures beside 774 OBJ files). A read is
started for each image file the scene's data names; the loader asks for its image where it
reads it anyway (`get`), and gets the decoded image, or the read's exception there, as if it had
read the file itself. A file nobody asks for is not waited on.
"""
import os
from concurrent.futures import ThreadPoolExecutor

from .files import not_a_file

WORKERS = 2


class ImagePrefetch:
    """`with ImagePrefetch() as images:` start(key, read, path, ...) begins read(path, ...) on a
    worker; get(key, read, path, ...) returns its result (raising its exception), or reads now
    when nothing was started under `key`. Leaving the block cancels the reads not yet begun."""

    def __init__(self):
        self._executor = None
        self._pending = {}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)

    def start(self, key, read, path, *args, **kwargs):
        # Only regular files: a named pipe would block its worker (the loader reports it).
        if key in self._pending or not_a_file(path) is not None:
            return
        if self._executor is None:
            self._executor = ThreadPoolExecutor(min(WORKERS, os.cpu_count() or 1), thread_name_prefix="image-read")
        self._pending[key] = self._executor.submit(read, path, *args, **kwargs)

    def get(self, key, read, path, *args, **kwargs):
        future = self._pending.pop(key, None)
        return future.result() if future is not None else read(path, *args, **kwargs)
