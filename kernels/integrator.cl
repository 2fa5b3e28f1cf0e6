// The megakernel: one work-item per pixel of the tile adds `frame.w` samples to its accumulator.
// Samples are taken in index order and added one by one, so the sum is the same however the
// samples are split into launches; the random numbers and the camera ray are keyed by the pixel
// of the full image, so a pixel's sum is also the same whichever tile holds it (distributed.py).
// With AOVS the sample-level AOVs accumulate beside it (aovs.h). When splatting (splat.h) the
// tile is the traced pixels and each sample is also written as a record for the gather.
//
// Launched over a third dimension (sample items, clrender/sample_items.py: GPUs, whose threads
// a small image would not fill), work-item k of that dimension takes sample `frame.z + k` alone
// and writes it as a record (with AOVS its AOVs too, into `aov_sums`, which is then the pass's
// AOV records); splat.cl's sum_samples then adds each pixel's records to its sums in sample
// order, so the sums are the same bits as the loop's.
#include "portability.h"
#include "rng.h"
#include "camera.h"
#include "scene.h"
#include "aovs.h"
#include "path.h"
#include "direct.h"
#include "aux_buffers.h"
#include "splat.h"

KERNEL void render_pass(RENDER_PASS_ARGUMENTS) {
    int tx = get_global_id(0), ty = first_row + (int)get_global_id(1);
    if (tx >= params->tile.z || ty >= params->tile.w) return;
    int x = params->tile.x + tx, y = params->tile.y + ty;
    int width = params->frame.x;
    Scene scene = SCENE_OF_RENDER_PASS_ARGUMENTS;
    int pixel = y * width + x;            // keys the random numbers
    int slot = ty * params->tile.z + tx;  // in this tile's buffers
    bool sample_items = get_global_size(2) > 1;
    int first = params->frame.z + (int)get_global_id(2);
    int end = sample_items ? first + 1 : first + params->frame.w;
    if (first == 0) write_aux(&scene, x, y, slot, aux_geometry, aux_object);
    float4 sum = (float4)(0.0f);
    if (!sample_items) sum = accumulator[slot];
#if AOVS
    AovSums aovs;
    if (!sample_items) aovs = aov_sums[slot];
#endif
    int discarded = 0;
    bool splatting = SPLATTING(params);
    // Pixels traced only to lend their samples to the target tile report no dropped samples:
    // their own tile does.
    bool reports = !splatting || IN_SPLAT_TILE(params, x, y);
    for (int s = first; s < end; ++s) {
        Rng rng = rng_for_path((uint)pixel, (uint)s, (uint)params->config.z, params->sampling.x);
        CameraSample camera = sample_camera(params, x, y, &rng);
        AovSample aov = aov_sample_none();
        float3 radiance = (direct_integrator(&scene) ? trace_direct(&scene, camera.ray, &rng, &aov)
                                                     : trace_path(&scene, camera.ray, &rng, &aov)) * camera.weight;
        // A non-finite sample is dropped (counted as black) and reported, never averaged in.
        bool finite = isfinite(radiance.x) && isfinite(radiance.y) && isfinite(radiance.z);
        discarded += finite || !reports ? 0 : 1;
        float3 value = finite ? radiance : (float3)(0.0f);
        int index = s - params->frame.z;   // of the pass
        if (splatting) write_splat_records(params, splat_records, index, slot, 1, value, camera.position);
        else if (sample_items) write_sample_radiance(params, splat_records, index, slot, 1, value);
#if AOVS
        aov_weight(&aov, camera.weight);
        if (sample_items) write_sample_aovs(params, aov_sums, index, slot, &aov, finite);
        else accumulate_aovs(&aovs, &aov, value, finite, sum);
#endif
        sum += (float4)(value, 1.0f);
    }
    if (!sample_items) accumulator[slot] = sum;
#if AOVS
    if (!sample_items) aov_sums[slot] = aovs;
#endif
    if (discarded > 0) atomic_add(discarded_samples, discarded);
}
