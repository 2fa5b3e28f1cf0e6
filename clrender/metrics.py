"""Error and efficiency measures used by tests, benchmarks and reports."""
import numpy as np


def mse(image, reference):
    return float(np.mean((np.asarray(image, float) - np.asarray(reference, float)) ** 2))


def rmse(image, reference):
    return float(np.sqrt(mse(image, reference)))


def relative_mse(image, reference, epsilon=1e-2):
    """Mean of (x - ref)^2 / (ref^2 + epsilon): weighs dark and bright regions alike."""
    image, reference = np.asarray(image, float), np.asarray(reference, float)
    return float(np.mean((image - reference) ** 2 / (reference ** 2 + epsilon)))


def efficiency(mse_value, seconds):
    """1 / (MSE x time): higher is better; independent of spp for an unbiased estimator."""
    return float("inf") if mse_value * seconds == 0 else 1.0 / (mse_value * seconds)


def variance_ratio(ours, theirs):
    """How much noisier `ours` is than `theirs`: the mean over pixels of the per-pixel variance
    across renders of one scene with different seeds (arrays (renders, ...), as many of each),
    ours over theirs, and its jackknife standard error over the renders (leaving one render of
    each out at a time)."""
    ours, theirs = np.asarray(ours, float), np.asarray(theirs, float)

    def leave_one_out(images):
        n = len(images)
        s1, s2 = images.sum(0), (images ** 2).sum(0)
        return np.array([np.mean(((s2 - x * x) - (s1 - x) ** 2 / (n - 1)) / (n - 2)) for x in images])
    ratio = float(ours.var(0, ddof=1).mean() / theirs.var(0, ddof=1).mean())
    partial = leave_one_out(ours) / leave_one_out(theirs)
    n = len(partial)
    return ratio, float(np.sqrt((n - 1) / n * np.sum((partial - partial.mean()) ** 2)))
