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
