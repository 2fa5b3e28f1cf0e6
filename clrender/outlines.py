"""Ink outlines from the pixel-centre record (depth, normal, object id; aovs.pixel_centre_record).

An *edge* lies between two neighbouring pixels (horizontal or vertical) when
  - silhouette: their object ids differ (the background has id -1), or, on one object, the depth
    jumps: 1 / depth, which is affine in the image over any plane, is extrapolated linearly from
    each side, and both predictions miss the other pixel by more than `depth_threshold` times
    1 / depth of the nearer one (so a receding floor is not an edge, a fold in front of its own
    body is);
  - crease: their normals differ by more than `crease_angle` degrees.
The ink line of `width` pixels is centred on the edges, at the midpoints between the two pixel
centres; a pixel at distance d from the nearest edge midpoint gets the coverage
clip(width / 2 + 0.5 - d, 0, 1) (a box-filtered line: antialiased, no extra samples needed).
"""
import numpy as np


def edges(aux, depth_threshold=0.1, crease_angle=30.0):
    """Boolean edge masks (edge_x, edge_y): edge_x[y, x] between pixels (y, x) and (y, x + 1),
    shape (H, W - 1); edge_y[y, x] between (y, x) and (y + 1, x), shape (H - 1, W)."""
    ids = aux["object_id"]
    hit = ids >= 0
    inverse_depth = np.where(hit, 1.0 / np.where(hit & (aux["depth"] > 0), aux["depth"], 1.0), 0.0)
    normal = aux["normal"]
    cos_limit = np.cos(np.radians(crease_angle))
    along_x = _edges_along_last_axis(ids, hit, inverse_depth, normal, depth_threshold, cos_limit)
    along_y = _edges_along_last_axis(ids.T, hit.T, inverse_depth.T, normal.transpose(1, 0, 2),
                                     depth_threshold, cos_limit).T
    return along_x, along_y


def _edges_along_last_axis(ids, hit, w, normal, depth_threshold, cos_limit):
    """Edges between [..., i] and [..., i+1] of 2-D arrays (see `edges`)."""
    p, q = np.s_[:, :-1], np.s_[:, 1:]
    silhouette = ids[p] != ids[q]
    both = hit[p] & hit[q] & ~silhouette
    # Slopes of 1 / depth on each side, from the outer neighbour when it lies on the same object
    # (else 0: constant extrapolation).
    slope = np.zeros_like(w)
    same_prev = np.zeros_like(hit)
    same_prev[:, 1:] = hit[:, 1:] & (ids[:, 1:] == ids[:, :-1])
    slope[:, 1:] = np.where(same_prev[:, 1:], w[:, 1:] - w[:, :-1], 0.0)
    slope_p = slope[p]                                   # w[i] - w[i-1]
    slope_q = np.zeros_like(w[q])
    slope_q[:, :-1] = slope[:, 2:]                       # w[i+2] - w[i+1]
    miss_q = np.abs(w[q] - (w[p] + slope_p))
    miss_p = np.abs(w[p] - (w[q] - slope_q))
    jump = np.minimum(miss_p, miss_q) > depth_threshold * np.maximum(w[p], w[q])
    cos_angle = np.sum(normal[p] * normal[q], axis=-1)
    crease = cos_angle < cos_limit
    return silhouette | (both & (jump | crease))


def coverage(edge_x, edge_y, shape, width=1.5):
    """Ink coverage in [0, 1] per pixel for lines of `width` pixels centred on the edges."""
    height, image_width = shape
    reach = width / 2.0 + 0.5          # coverage falls to 0 at this distance from an edge
    distance = np.full(shape, np.inf)
    # Edge midpoints: (x + 0.5, y) for edge_x[y, x], (x, y + 0.5) for edge_y[y, x].
    for mask, ox, oy in ((edge_x, 0.5, 0.0), (edge_y, 0.0, 0.5)):
        k = int(np.ceil(reach)) + 1
        padded = np.zeros((height + 2 * k, image_width + 2 * k), bool)
        padded[k:k + mask.shape[0], k:k + mask.shape[1]] = mask
        for sy in range(-k, k + 1):
            for sx in range(-k, k + 1):
                d = np.hypot(sx + ox, sy + oy)
                if d >= reach:
                    continue
                shifted = padded[k + sy:k + sy + height, k + sx:k + sx + image_width]
                distance = np.where(shifted, np.minimum(distance, d), distance)
    return np.clip(reach - distance, 0.0, 1.0).astype(np.float32)


def outline_alpha(aux, width=1.5, depth_threshold=0.1, crease_angle=30.0):
    """Per-pixel ink coverage (H, W) for the outlines of the aux buffers."""
    edge_x, edge_y = edges(aux, depth_threshold, crease_angle)
    return coverage(edge_x, edge_y, aux["object_id"].shape, width)


def composite(image, alpha, color):
    """Ink over the linear image; pixels without ink are returned bit for bit."""
    a = alpha[..., None]
    inked = image * (1.0 - a) + np.asarray(color, dtype=np.float32) * a
    return np.where(a > 0, inked, image).astype(np.float32)


def apply_outlines(image, aux, settings):
    """(image with outlines, alpha) for a scene's Outlines settings; (image, None) if disabled."""
    if settings is None or not settings.enabled:
        return image, None
    alpha = outline_alpha(aux, settings.width, settings.depth_threshold, settings.crease_angle)
    return composite(image, alpha, settings.color), alpha
