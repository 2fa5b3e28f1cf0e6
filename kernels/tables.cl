// The tables a scene's rough materials read, computed on the device from the microfacet code that
// renders (built with LANES 1 and DIELECTRIC 1 whatever the scene's program: features.py,
// TABLE_FEATURES): energy compensation (materials/energy.h) and plastic's coat
// (materials/plastic_coat.h).
#include "portability.h"
#include "materials/energy.h"
#include "materials/plastic_coat.h"
