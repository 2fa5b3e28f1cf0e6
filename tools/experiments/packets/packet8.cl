// PROTOTYPE, for a measurement (docs/performance.md, "Explicit ray packets"): the megakernel's
// path tracer with 8 camera paths per work-item, their state in float8 lanes (SIMD across rays,
// written out by hand: PoCL does not vectorise across work-items, see that section). Scope: the
// benchmark's surface scenes: diffuse and smooth-dielectric triangles and spheres, triangle
// emitters, no media, environment, toon, AOVs or one-sided materials; the image width a
// multiple of 8 and one launch for the whole frame. Traversal stays the scalar traverse_bvh,
// one lane after another. Same random numbers (Sobol dimensions) as the megakernel, so the
// images agree pixel for pixel up to float rounding. Built on its own, with LANES 8 (lanes.h):
// the random numbers are kernels/rng.h itself, over 8 lanes.
#include "types.h"
#include "math.h"
#include "scene.h"
#include "rng.h"
#include "sampling.h"
#include "materials/diffuse.h"
#include "materials/dielectric_smooth.h"

float8 v8_maxc(lane_float3 a) { return fmax(a.x, fmax(a.y, a.z)); }
int8 v8_black(lane_float3 a) { return a.x == 0.0f & a.y == 0.0f & a.z == 0.0f; }

#define LOADV(name, arr) lane_float3 name = make_lane_float3(vload8(0, arr[0]), vload8(0, arr[1]), vload8(0, arr[2]))

lane_float3 trace_path8(const Scene* scene, lane_float3 org, lane_float3 dir, Rng* rng) {
    int max_depth = scene->params->config.x, rr_depth = scene->params->config.y;
    int count = scene->params->config.w;
    lane_float3 radiance = l3_splat(0.0f), thr = l3_splat(1.0f), prev_p = org;
    float8 prev_pdf = 0.0f, eta_scale = 1.0f;
    int8 prev_delta = (int8)(-1), alive = (int8)(-1);
    for (int depth = 1; depth <= max_depth; ++depth) {
        float o[3][8], d[3][8];
        vstore8(org.x, 0, o[0]); vstore8(org.y, 0, o[1]); vstore8(org.z, 0, o[2]);
        vstore8(dir.x, 0, d[0]); vstore8(dir.y, 0, d[1]); vstore8(dir.z, 0, d[2]);
        int live[8]; vstore8(alive, 0, live);
        float ta[8], b1a[8], b2a[8], fa[3][8]; int prima[8], spha[8];
        for (int i = 0; i < 8; ++i) {
            Hit h; h.t = INFINITY; h.prim = -1; h.b1 = h.b2 = 0.0f; h.sphere = false;
            h.from_centre = (float3)(0.0f);
            if (live[i]) traverse_bvh(scene->nodes, scene->triangles, (float3)(o[0][i], o[1][i], o[2][i]),
                                      (float3)(d[0][i], d[1][i], d[2][i]), false, &h);
            ta[i] = h.t; b1a[i] = h.b1; b2a[i] = h.b2; prima[i] = h.prim; spha[i] = h.sphere ? -1 : 0;
            fa[0][i] = h.from_centre.x; fa[1][i] = h.from_centre.y; fa[2][i] = h.from_centre.z;
        }
        int8 prim = vload8(0, prima);
        alive &= prim >= 0;
        if (!any(alive)) break;
        LaneHit hit;
        hit.t = vload8(0, ta); hit.b1 = vload8(0, b1a); hit.b2 = vload8(0, b2a);
        hit.prim = max(prim, 0);
        hit.sphere = vload8(0, spha);
        hit.from_centre = make_lane_float3(vload8(0, fa[0]), vload8(0, fa[1]), vload8(0, fa[2]));
        SurfacePoint sp = surface_point(scene, &hit, dir);
        lane_float3 p = sp.p, ng = sp.ng, ns = sp.ns;
        float8 p_error = sp.p_error;
        int8 front = sp.front_face;
        lane_float3 albedo = LANE_LOAD3(scene->materials, sp.material, .color);
        lane_float3 emission = LANE_LOAD3(scene->materials, sp.material, .emission);
        int8 glass = LANE_LOAD_INT(scene->materials, sp.material, .kind.x) == MATERIAL_DIELECTRIC;
        float8 ior = LANE_LOAD(scene->materials, sp.material, .params.x);
        float8 ext = LANE_LOAD(scene->materials, sp.material, .params.y);
        int8 emitter = sp.emitter, ei = max(emitter, 0);
        float8 area = LANE_LOAD(scene->emitters, ei, .p0.w);
        float8 pmf_hit = select((float8)(0.0f), emitter_selection_pmf(scene, ei), emitter >= 0);
        // emission
        int8 emits = alive & front & (emitter >= 0);
        if (any(emits)) {
            lane_float3 dp = l3_sub(p, prev_p);
            float8 dist = sqrt(l3_dot(dp, dp));
            float8 cos_light = -l3_dot(dir, ng);
            float8 light_pdf = pmf_hit * select((float8)(0.0f), dist * dist / (cos_light * area), cos_light > 0.0f);
            float8 w = select(power_heuristic(prev_pdf, light_pdf), (float8)(1.0f), prev_delta);
            radiance = l3_select(radiance, l3_add(radiance, l3_scale(l3_mul(thr, emission), w)), emits);
        }
        if (depth == max_depth) break;
        // next-event estimation
        float8 ux, uy;
        { lane_float2 u2 = rng_float2(rng); ux = u2.x; uy = u2.y; }
        float8 rnl = ux;
        // Branchless binary search: every lane halves the same length, so the trip count is uniform.
        int8 lidx = (int8)(0);
        for (int len = count; len > 1; ) {
            int step = len >> 1;
            int8 mid = lidx + step;
            lidx = select(lidx, mid, LANE_LOAD(scene->emitter_cdf, mid, ) <= ux);
            len -= step;
        }
        float8 c0 = LANE_LOAD(scene->emitter_cdf, lidx, ), c1 = LANE_LOAD(scene->emitter_cdf, lidx + 1, );
        float8 lux = clamp((ux - c0) / fmax(c1 - c0, 1e-30f), 0.0f, 0x1.fffffep-1f);
        float8 pmf = c1 - c0, larea = LANE_LOAD(scene->emitters, lidx, .p0.w);
        lane_float3 lp0 = LANE_LOAD3(scene->emitters, lidx, .p0), le1 = LANE_LOAD3(scene->emitters, lidx, .e1);
        lane_float3 le2 = LANE_LOAD3(scene->emitters, lidx, .e2), lrad = LANE_LOAD3(scene->emitters, lidx, .radiance);
        lane_float2 barycentrics = sample_triangle(make_lane_float2(lux, uy));
        float8 bx = barycentrics.x, by = barycentrics.y;
        lane_float3 n_light = l3_normalize(l3_cross(le1, le2));
        lane_float3 q = l3_add(lp0, l3_add(l3_scale(le1, bx), l3_scale(le2, by)));
        lane_float3 lmag = l3_add(l3_abs(lp0), l3_add(l3_abs(le1), l3_abs(le2)));
        q = offset_ray_origin(q, l3_select(l3_neg(n_light), n_light, l3_dot(l3_sub(p, q), n_light) > 0.0f),
                           SURFACE_ERROR_EPS * l3_dot(l3_abs(n_light), lmag));
        lane_float3 dq = l3_sub(q, p);
        float8 dist = sqrt(l3_dot(dq, dq));
        lane_float3 wi = l3_scale(dq, 1.0f / dist);
        float8 cos_light = -l3_dot(wi, n_light);
        float8 lpdf = pmf * select((float8)(0.0f), dist * dist / (cos_light * larea), cos_light > 0.0f);
        lane_float3 f = eval_diffuse(albedo, &sp, wi);
        int8 ok = alive & ~glass & (dist > 0.0f) & (lpdf > 0.0f) & ~v8_black(lrad) & ~v8_black(f);
        if (any(ok)) {
            lane_float3 so = spawn_ray_origin(&sp, wi);
            float s[3][8], w3[3][8], dd[8]; int oka[8], vis[8];
            vstore8(so.x, 0, s[0]); vstore8(so.y, 0, s[1]); vstore8(so.z, 0, s[2]);
            vstore8(wi.x, 0, w3[0]); vstore8(wi.y, 0, w3[1]); vstore8(wi.z, 0, w3[2]);
            vstore8(dist, 0, dd); vstore8(ok, 0, oka);
            for (int i = 0; i < 8; ++i)
                vis[i] = oka[i] && !occluded(scene, (float3)(s[0][i], s[1][i], s[2][i]),
                                             (float3)(w3[0][i], w3[1][i], w3[2][i]), dd[i]) ? -1 : 0;
            int8 visible = vload8(0, vis);
            float8 w = power_heuristic(lpdf, sample_diffuse_pdf(&sp, wi)) / lpdf;
            radiance = l3_select(radiance, l3_add(radiance, l3_scale(l3_mul(l3_mul(thr, f), lrad), w)), visible);
        }
        // BSDF sample
        { lane_float2 u2 = rng_float2(rng); ux = u2.x; uy = u2.y; }
        wi = sample_diffuse(&sp, make_lane_float2(ux, uy));
        float8 bpdf = sample_diffuse_pdf(&sp, wi);
        lane_float3 weight = albedo;
#if DIELECTRIC
        if (any(glass & alive)) {
            lane_float3 wo = l3_neg(dir);
            lane_float3 n = l3_select(ng, ns, l3_dot(wo, ns) > 0.0f);
            BsdfSample gs = sample_dielectric_delta(albedo, select(ext / ior, ior / ext, front), n, ng, wo, rnl);
            eta_scale = select(eta_scale, eta_scale * gs.eta * gs.eta, glass);
            wi = l3_select(wi, gs.wi, glass);
            weight = l3_select(weight, gs.weight, glass);
            bpdf = select(bpdf, gs.pdf_w, glass);
        }
#endif
        alive &= (bpdf > 0.0f) & ~v8_black(weight);
        thr = l3_mul(thr, weight);
        prev_pdf = bpdf; prev_delta = glass; prev_p = p;
        org = spawn_ray_origin(&sp, wi);
        dir = wi;
        if (depth >= rr_depth) {
            float8 u = rng_float(rng);
            float8 survive = fmin(v8_maxc(thr) * eta_scale, 0.95f);
            alive &= u < survive;
            thr = l3_scale(thr, 1.0f / survive);
        }
        if (!any(alive)) break;
    }
    return radiance;
}

__kernel void render_packet8(__constant RenderParams* params, __global const WideBvhNode* nodes,
                             __global const Triangle* triangles, __global const TriangleShading* shading,
                             __global const TriangleInfo* info, __global const Material* materials,
                             __global const Emitter* emitters, __global const float* emitter_cdf,
                             __global float4* accumulator) {
    int gx = get_global_id(0), y = get_global_id(1);
    int width = params->frame.x, height = params->frame.y;
    int x0 = gx * 8;
    if (x0 >= width || y >= height) return;
    Scene scene = {params, nodes, triangles, shading, info, materials, 0, emitters, emitter_cdf, 0, 0, 0, 0, 0};
    int8 xs = x0 + (int8)(0, 1, 2, 3, 4, 5, 6, 7);
    uint8 pixel = convert_uint8(y * width + xs);
    __constant Camera* cam = &params->camera;
    lane_float3 sum = l3_splat(0.0f);
    int first = params->frame.z;
    for (int s = first; s < first + params->frame.w; ++s) {
        Rng rng = rng_for_path(pixel, (uint)s, (uint)params->config.z, params->sampling.x);
        lane_float2 jitter = rng_float2(&rng);
        float8 jx = jitter.x, jy = jitter.y;
        float8 sx = 2.0f * (convert_float8(xs) + jx) / (float)width - 1.0f;
        float8 sy = 1.0f - 2.0f * ((float)y + jy) / (float)height;
        lane_float3 d = make_lane_float3(cam->forward.x + sx * cam->right.x + sy * cam->up.x,
                  cam->forward.y + sx * cam->right.y + sy * cam->up.y,
                  cam->forward.z + sx * cam->right.z + sy * cam->up.z);
        d = l3_normalize(d);
        lane_float3 o = make_lane_float3((float8)(cam->origin.x), (float8)(cam->origin.y), (float8)(cam->origin.z));
        lane_float3 rad = trace_path8(&scene, o, d, &rng);
        int8 finite = isfinite(rad.x) & isfinite(rad.y) & isfinite(rad.z);
        sum = l3_add(sum, l3_select(l3_splat(0.0f), rad, finite));
    }
    float a[3][8];
    vstore8(sum.x, 0, a[0]); vstore8(sum.y, 0, a[1]); vstore8(sum.z, 0, a[2]);
    for (int i = 0; i < 8; ++i)
        accumulator[y * width + x0 + i] += (float4)(a[0][i], a[1][i], a[2][i], (float)params->frame.w);
}
