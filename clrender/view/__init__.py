"""Live preview: `clrender view SCENE` and `clrender.view(scene)` show the image converging in a
web page, with exposure and tone map, the AOVs, the denoised image, camera moves and save
(docs/viewer.md). aiohttp (the `view` extra) serves it; the modules:
    camera.py    orbit, pan, dolly of a scene.Camera
    session.py   the render loop: passes, snapshots, cancellation by a camera move
    frames.py    the layers of a snapshot and the binary frame messages
    tonemap.py   exposure and tone-map curves (the page's, for the saved PNG)
    output.py    the save action: EXR with layers, PNG as shown
    server.py    the web server: token, page, WebSocket protocol
    viewer.py    Viewer (session + server in threads) and view()
    notebook.py  Jupyter: the page in an iframe
    static/      the page: index.html, viewer.js, viewer.css
"""
from .viewer import Viewer, view

__all__ = ["Viewer", "view"]
