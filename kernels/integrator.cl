// The megakernel: one work-item per pixel adds `frame.w` samples to its accumulator.
// Samples are taken in index order and added one by one, so the sum is the same however the
// samples are split into launches.
#include "portability.h"
#include "types.h"
#include "math.h"
#include "rng.h"
#include "sampling.h"
#include "camera.h"
#include "bvh.h"
#include "scene.h"
#include "lights.h"
#include "materials/bsdf_sample.h"
#include "materials/diffuse.h"
#include "materials/microfacet.h"
#include "materials/dielectric.h"
#include "materials/conductor.h"
#include "materials/energy.h"
#include "materials/bsdf.h"
#include "materials/toon.h"
#if MEDIA
#include "media/phase.h"
#include "media/homogeneous.h"
#endif
#if GRID_MEDIA
#include "media/grid.h"
#include "media/majorant.h"
#endif
#if GRID_MEDIA == VOLUME_NULL
#include "media/null_scattering.h"
#elif GRID_MEDIA == VOLUME_RAYMARCH
#include "media/raymarch.h"
#endif
#include "path.h"
#include "aux_buffers.h"

KERNEL void render_pass(__constant RenderParams* params,
                        __global const WideBvhNode* nodes,
                        __global const Triangle* triangles,
                        __global const TriangleShading* shading,
                        __global const TriangleInfo* info,
                        __global const Material* materials,
                        __global const Medium* media,
                        __global const Emitter* emitters,
                        __global const float* emitter_cdf,
                        __global const float4* env_texels,
                        __global const float* env_cdf,
                        __global const float* specular_albedo,
                        __global const float* grid_data,
                        __global const float* majorant_data,
                        __global float4* accumulator,
                        __global int* discarded_samples,
                        __global float4* aux_geometry,
                        __global int* aux_object) {
    int x = get_global_id(0), y = get_global_id(1);
    int width = params->frame.x, height = params->frame.y;
    if (x >= width || y >= height) return;
    Scene scene = {params, nodes, triangles, shading, info, materials, media, emitters,
                   emitter_cdf, env_texels, env_cdf, specular_albedo, grid_data, majorant_data};
    int pixel = y * width + x;
    if (params->frame.z == 0) write_aux(&scene, x, y, pixel, aux_geometry, aux_object);
    float4 sum = accumulator[pixel];
    int discarded = 0;
    int first = params->frame.z;
    for (int s = first; s < first + params->frame.w; ++s) {
        Rng rng = rng_for_sample((uint)pixel, (uint)s, (uint)params->config.z);
        Ray ray = camera_ray(&params->camera, x, y, width, height, rng_float2(&rng));
        float3 radiance = trace_path(&scene, ray, &rng);
        // A non-finite sample is dropped (counted as black) and reported, never averaged in.
        bool finite = isfinite(radiance.x) && isfinite(radiance.y) && isfinite(radiance.z);
        discarded += finite ? 0 : 1;
        sum += (float4)(finite ? radiance : (float3)(0.0f), 1.0f);
    }
    accumulator[pixel] = sum;
    if (discarded > 0) atomic_add(discarded_samples, discarded);
}
