"""Samplers: `render.spp`, `render.seed` and `render.sampler`.

| plugin | parameter (Mitsuba's default) | clrender |
|---|---|---|
| `independent` | `sample_count` (4), `seed` (0) | `render.sampler` "sobol" |
| `stratified`, `multijitter` | the same; sample_count rounded up to a square | "sobol" |
| `orthogonal` | the same; rounded up to the square of a prime | "sobol" |
| `ldsampler` | the same; rounded up to a power of two | "sobol" |
| accepted | `jitter`, `strength`, `dimension`, `scramble_seed` | |
| none | | 4 spp, seed 0 (Mitsuba's default), "sobol" |
"""
import numpy as np

SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")


def read_sampler(plugin, reader):
    """(spp, seed, our render.sampler); plugin None: the sensor has none. Samplers differ in how
    they stratify, not in what they estimate, and clrender's padded Owen-scrambled Sobol sampler
    stratifies at least as well as any of them, so each becomes it, Mitsuba's `independent` (its
    default) too: a scene renders with less error at its sample count (independent numbers stay
    a choice: `--sampler independent`, `render.sampler`). The sample count is rounded as
    Mitsuba's samplers round it."""
    if plugin is None:
        return 4, 0, "sobol"
    if plugin.type not in SAMPLERS:
        raise plugin.error(f"unsupported sampler '{plugin.type}' (supported: {', '.join(SAMPLERS)})")
    count = plugin.integer("sample_count", 4)
    seed = plugin.integer("seed", 0)
    if count < 1:
        raise plugin.error(f"sample_count must be >= 1, got {count}")
    plugin.accept("jitter", "strength", "dimension", "scramble_seed")
    plugin.finish()
    if plugin.type in ("stratified", "multijitter"):
        count = int(np.ceil(np.sqrt(count))) ** 2
    elif plugin.type == "ldsampler":
        count = 1 << int(np.ceil(np.log2(count)))
    elif plugin.type == "orthogonal":
        root = int(np.ceil(np.sqrt(count)))
        while any(root % d == 0 for d in range(2, int(np.sqrt(root)) + 1)) or root < 2:
            root += 1
        count = root * root
    return count, seed % 2**32, "sobol"
