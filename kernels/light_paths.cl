// PROTOTYPE (branch light-tracing-prototype): light tracing of the paths light -> delta+ ->
// non-delta -> ... -> camera, which a path tracer built with LIGHT_TRACED_CAUSTICS leaves out.
// One light path per work-item; its connections to the (pinhole) camera are written as records
// (image x, y in pixels, 0, 0) and (rgb, 0), at most MAX_CONNECTIONS per path (then the walk
// stops: max depth bounds it below that in the measured scenes).
#include "portability.h"
#include "rng.h"
#include "camera.h"
#include "scene.h"
#include "path.h"

#define MAX_CONNECTIONS 8

KERNEL void light_paths(__constant RenderParams* params, __global const WideBvhNode* nodes,
    __global const TriangleBlock* blocks, __global const Sphere* spheres, __global const TriangleShading* shading,
    __global const TriangleInfo* info, __global const Material* materials, __global const Medium* media,
    __global const Emitter* emitters, __global const float* emitter_cdf, __global const float4* env_texels,
    __global const float* env_cdf, __global const float* specular_albedo, __global const float* grid_data,
    __global const float* majorant_data, __global const float2* uvs, __global const Texture* textures,
    __global const uchar* texels, __global float4* records, int first_path) {
    int item = get_global_id(0);
    Scene scene = SCENE_OF_RENDER_PASS_ARGUMENTS;
    for (int c = 0; c < 2 * MAX_CONNECTIONS; ++c) records[item * 2 * MAX_CONNECTIONS + c] = (float4)(0.0f);
    Rng rng = rng_for_sample((uint)(first_path + item), 0x51ed27u, (uint)params->config.z);
    int count = params->config.w;
    if (count == 0) return;
    float2 u = rng_float2(&rng);
    float u_on;
    int index = sample_discrete_cdf_reuse(scene.emitter_cdf, count, u.x, &u_on);
    u.x = u_on;
    __global const Emitter* e = scene.emitters + index;
    if (e->kind.x != EMITTER_TRIANGLE || e->radiance.w >= 0.0f) return;   // untextured triangles only
    float pmf = emitter_selection_pmf(&scene, index);
    float3 p0 = e->p0.xyz, e1 = e->e1.xyz, e2 = e->e2.xyz;
    float area = e->p0.w;
    float2 b = sample_triangle(u);
    float3 n = normalize(cross(e1, e2));
    float3 q = p0 + b.x * e1 + b.y * e2;
    float3 dir = to_world(sample_cosine_hemisphere(rng_float2(&rng)), n);
    // Le cos / (pmf (1 / area) (cos / pi))
    float3 beta = e->radiance.xyz * (PI_F * area / pmf);
    float3 origin = q + n * (1e-4f * (fabs(q.x) + fabs(q.y) + fabs(q.z) + 1.0f));
    int max_depth = params->config.x;
    int chain = 0;          // delta vertices met since the light, before the first non-delta one
    bool caustic = false;   // the path has passed light -> delta+ -> non-delta
    int connections = 0;
    float3 right = params->camera.right.xyz, up = params->camera.up.xyz, forward = params->camera.forward.xyz;
    float3 eye = params->camera.origin.xyz;
    float image_area = 4.0f * length(right) * length(up);
    int width = params->frame.x, height = params->frame.y;
    for (int m = 1; m < max_depth; ++m) {   // vertex m of the light path; m + 1 <= max_depth with the camera
        Hit hit;
        if (!intersect_scene(&scene, origin, dir, INFINITY, &hit)) return;
        SurfacePoint sp = surface_point(&scene, &hit, dir);
        Material mat = surface_material(&scene, &sp);
        float3 wl = -dir;   // towards the light
        bool delta = material_is_delta(&mat);
        if (!delta) {
            if (!caustic && chain == 0) return;   // light -> non-delta first: the path tracer's
            caustic = true;
            // Join to the camera.
            float3 to_eye = eye - sp.p;
            float dist = length(to_eye);
            float3 wc = to_eye / dist;
            float3 v = -wc;
            float z = dot(v, forward);
            if (z > 0.0f) {
                float sx = dot(v, right) / (dot(right, right) * z), sy = dot(v, up) / (dot(up, up) * z);
                float px = (sx + 1.0f) * 0.5f * (float)width, py = (1.0f - sy) * 0.5f * (float)height;
                if (px >= 0.0f && px < (float)width && py >= 0.0f && py < (float)height) {
                    float3 fcos = eval_bsdf(&scene, &mat, &sp, wl, wc);   // f |cos| towards the camera
                    if (!is_black(fcos) && !occluded(&scene, spawn_ray_origin(&sp, wc), wc, dist * (1.0f - 1e-4f))) {
                        float cos_cam = z / length(v);
                        float3 value = beta * fcos / (image_area * cos_cam * cos_cam * cos_cam * dist * dist);
                        int slot = item * 2 * MAX_CONNECTIONS + 2 * connections;
                        records[slot] = (float4)(px, py, 0.0f, 0.0f);
                        records[slot + 1] = (float4)(value, 0.0f);
                    }
                }
            }
            if (++connections == MAX_CONNECTIONS) return;
        } else if (!caustic) {
            ++chain;
        }
        BsdfSample bs = sample_bsdf(&scene, &mat, &sp, wl, &rng);
        if (!(bs.pdf_w > 0.0f) || is_black(bs.weight)) return;
        // Importance: no 1 / eta^2 of radiance at a refraction (pbrt-v4's TransportMode).
        beta *= bs.weight * (bs.eta * bs.eta);
        origin = spawn_ray_origin(&sp, bs.wi);
        dir = bs.wi;
    }
}
