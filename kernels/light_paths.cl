// Light paths (light_paths.h says which paths they take): one per `light_paths.y` camera samples
// of each pixel of the tile, for the pass's samples (frame.z, frame.w), keyed by that pixel and
// sample, so a tile's passes trace the same light paths however they are split. Each joins the
// camera (a pinhole) at its non-delta vertices; every join is a record (image x, y in pixels,
// 0, 0), (radiance weight, 0) appended at an atomic counter (the host sums the records in fixed
// point, exactly, so their order does not matter). A count beyond `capacity` means the records
// did not fit: the host launches again with room for them.
#include "portability.h"
#include "rng.h"
#include "sampling.h"
#include "scene.h"
#include "lights.h"
#include "materials/material.h"
#include "materials/bsdf.h"
#include "materials/textured_params.h"

// The path's weight (radiance x cos / pdf so far) joined to the camera from sp, its event there
// turning light arriving from wl towards the camera: the record, if the camera sees sp.
void join_camera(const Scene* scene, const Material* m, const SurfacePoint* sp, float3 wl, float3 weight,
                 __global float4* records, __global int* count, int capacity) {
    __constant Camera* camera = &scene->params->camera;
    float3 to_eye = camera->origin.xyz - sp->p;
    float dist = length(to_eye);
    float3 wc = to_eye / dist;
    float z = -dot(wc, camera->forward.xyz);   // cos of the angle to the view axis
    if (!(z > 0.0f)) return;
    float3 right = camera->right.xyz, up = camera->up.xyz;
    float sx = -dot(wc, right) / (dot(right, right) * z), sy = -dot(wc, up) / (dot(up, up) * z);
    int width = scene->params->frame.x, height = scene->params->frame.y;
    float px = (sx + 1.0f) * 0.5f * (float)width, py = (1.0f - sy) * 0.5f * (float)height;
    if (!(px >= 0.0f && px < (float)width && py >= 0.0f && py < (float)height)) return;
    // f |cos| towards the camera, and the shading normal's correction of importance (Veach 1997, 5.3).
    float3 f = eval_bsdf(scene, m, sp, wl, wc) *
               (fabs(dot(wl, sp->ns)) * fabs(dot(wc, sp->ng)) / fmax(fabs(dot(wl, sp->ng)) * fabs(dot(wc, sp->ns)), 1e-12f));
    if (is_black(f) || occluded(scene, spawn_ray_origin(sp, wc), wc, dist * (1.0f - 1e-4f))) return;
    // The pinhole's importance 1 / (A cos^4) over the image plane at distance 1 (area A), times
    // the join's cos / dist^2 at the camera.
    float image_area = 4.0f * length(right) * length(up);
    float3 value = weight * f / (image_area * z * z * z * dist * dist);
    int slot = atomic_inc(count);
    if (slot >= capacity) return;
    records[2 * slot] = (float4)(px, py, 0.0f, 0.0f);
    records[2 * slot + 1] = (float4)(value, 0.0f);
}

// One light path, from its random numbers.
void trace_light_path(const Scene* scene, Rng* rng, __global float4* records, __global int* count, int capacity) {
    int emitters = scene->params->config.w;
    if (emitters == 0) return;
    float2 u = rng_float2(rng);
    float u_on;
    int index = sample_discrete_cdf_reuse(scene->emitter_cdf, emitters, u.x, &u_on);
    __global const Emitter* e = scene->emitters + index;
    if (e->kind.x != EMITTER_TRIANGLE || e->radiance.w >= 0.0f) return;   // the light paths' emitters (light_paths.h)
    float pmf = emitter_selection_pmf(scene, index);
    float3 e1 = e->e1.xyz, e2 = e->e2.xyz;
    float2 b = sample_triangle((float2)(u_on, u.y));
    float3 n = normalize(cross(e1, e2));   // the emitting side
    float3 q = e->p0.xyz + b.x * e1 + b.y * e2;
    float3 dir = to_world(sample_cosine_hemisphere(rng_float2(rng)), n);
    // Le cos / (pmf / area x cos / pi)
    float3 weight = e->radiance.xyz * (PI_F * e->p0.w / pmf);
    float3 magnitude = fabs(e->p0.xyz) + fabs(e1) + fabs(e2);
    float3 origin = offset_ray_origin(q, n, SURFACE_ERROR_EPS * dot(fabs(n), magnitude));
    int delta_prefix = 0;   // the delta events before the first non-delta one
    bool smooth_seen = false;
    // Vertex m of the light path is vertex max_depth - m + 1 ... of the camera path it joins:
    // with the camera, m + 1 <= max depth.
    for (int m = 1; m < scene->params->config.x; ++m) {
        Hit hit;
        if (!intersect_scene(scene, origin, dir, INFINITY, &hit)) return;
        SurfacePoint sp = surface_point(scene, &hit, dir);
        Material mat = surface_material(scene, &sp);
        float3 wl = -dir;
        if (delta_prefix >= 1 && !material_is_delta(&mat))
            join_camera(scene, &mat, &sp, wl, weight, records, count, capacity);
        BsdfSample bs = sample_bsdf(scene, &mat, &sp, wl, rng);
        if (!(bs.pdf_w > 0.0f) || is_black(bs.weight)) return;
        if (!smooth_seen) {
            if (!bs.delta && delta_prefix == 0) return;   // light -> non-delta first: the path tracer's
            smooth_seen = !bs.delta;
            delta_prefix += bs.delta ? 1 : 0;
        }
        // Importance carries no 1 / eta^2 of radiance at a refraction (pbrt-v4's TransportMode),
        // and the shading normal's correction.
        float correction = fabs(dot(wl, sp.ns)) * fabs(dot(bs.wi, sp.ng)) /
                           fmax(fabs(dot(wl, sp.ng)) * fabs(dot(bs.wi, sp.ns)), 1e-12f);
        weight *= bs.weight * (bs.eta * bs.eta) * (bs.delta ? 1.0f : correction);
        origin = spawn_ray_origin(&sp, bs.wi);
        dir = bs.wi;
    }
}

KERNEL void light_paths(RENDER_SCENE_ARGUMENTS, __global float4* records, __global int* count, int capacity) {
    int tx = get_global_id(0), ty = get_global_id(1);
    if (tx >= params->tile.z || ty >= params->tile.w) return;
    Scene scene = SCENE_OF_RENDER_PASS_ARGUMENTS;
    int pixel = (params->tile.y + ty) * params->frame.x + params->tile.x + tx;
    int every = params->light_paths.y;
    int first = params->frame.z, end = first + params->frame.w;
    for (int s = (first + every - 1) / every * every; s < end; s += every) {
        Rng rng = rng_for_sample((uint)pixel, (uint)s, (uint)params->config.z ^ 0x9e3779b9u);
        trace_light_path(&scene, &rng, records, count, capacity);
    }
}
