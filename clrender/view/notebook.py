"""Jupyter: the viewer's page inline, in an iframe (Viewer._repr_html_). IPython is optional: it
is only looked at when the caller has imported it already (a notebook kernel has)."""
import html
import sys

# Room for the page's tool bar and status line above and below the image, in CSS pixels.
CONTROLS_HEIGHT = 150
MAX_IFRAME_HEIGHT = 900


def in_notebook():
    """Whether this is a Jupyter kernel (IPython's kernel app), where output is HTML."""
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


def iframe(url, height):
    """The HTML of the page at `url` inline, tall enough for an image `height` pixels high."""
    rows = min(height + CONTROLS_HEIGHT, MAX_IFRAME_HEIGHT)
    return (f'<iframe src="{html.escape(url, quote=True)}" width="100%" height="{rows}" '
            'style="border: 0" title="clrender view"></iframe>')
