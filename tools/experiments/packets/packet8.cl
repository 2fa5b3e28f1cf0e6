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

float8 v8_maxc(lane_float3 a) { return fmax(a.x, fmax(a.y, a.z)); }
int8 v8_black(lane_float3 a) { return a.x == 0.0f & a.y == 0.0f & a.z == 0.0f; }

float8 fresnel8(float8 cos_i, float8 eta) {
    cos_i = clamp(cos_i, 0.0f, 1.0f);
    float8 g2 = eta * eta - 1.0f + cos_i * cos_i;
    float8 cos_t = select((float8)(-1.0f), sqrt(g2) / eta, g2 > 0.0f);
    float8 rpa = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    float8 rpe = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float8 f = 0.5f * (rpa * rpa + rpe * rpe);
    f = select(f, (float8)(1.0f), (cos_t <= 0.0f) | (cos_i == 0.0f));
    return select(f, (float8)(0.0f), eta == 1.0f);
}
lane_float3 reflect8(lane_float3 wo, lane_float3 n) { return l3_normalize(l3_sub(l3_scale(n, 2.0f * l3_dot(wo, n)), wo)); }
int8 refract8(lane_float3 wo, lane_float3 n, float8 eta, lane_float3* wt) {
    float8 cos_i = clamp(l3_dot(n, wo), 0.0f, 1.0f);
    float8 g2 = eta * eta - 1.0f + cos_i * cos_i;
    float8 cos_t = select((float8)(-1.0f), sqrt(g2) / eta, g2 > 0.0f);
    *wt = l3_normalize(l3_add(l3_scale(wo, -1.0f / eta), l3_scale(n, cos_i / eta - cos_t)));
    return cos_t > 0.0f;
}

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
        float8 cos_ng = l3_dot(ng, wi), cos_ns = fmax(l3_dot(ns, wi), 0.0f);
        lane_float3 f = l3_scale(albedo, select(cos_ns * INV_PI_F, (float8)(0.0f), cos_ng <= 0.0f));
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
            float8 bpdf = select(cos_ns * INV_PI_F, (float8)(0.0f), cos_ng <= 0.0f);
            float8 w = power_heuristic(lpdf, bpdf) / lpdf;
            radiance = l3_select(radiance, l3_add(radiance, l3_scale(l3_mul(l3_mul(thr, f), lrad), w)), visible);
        }
        // BSDF sample
        { lane_float2 u2 = rng_float2(rng); ux = u2.x; uy = u2.y; }
        wi = to_world(sample_cosine_hemisphere(make_lane_float2(ux, uy)), ns);
        cos_ng = l3_dot(ng, wi);
        float8 bpdf = select(fmax(l3_dot(ns, wi), 0.0f) * INV_PI_F, (float8)(0.0f), cos_ng <= 0.0f);
        lane_float3 weight = albedo;
        if (any(glass & alive)) {
            lane_float3 wo = l3_neg(dir);
            lane_float3 n = l3_select(ng, ns, l3_dot(wo, ns) > 0.0f);
            float8 eta = select(ext / ior, ior / ext, front);
            float8 fr = fresnel8(l3_dot(n, wo), eta);
            int8 reflected = rnl < fr;
            lane_float3 wt, wt2;
            int8 ok1 = refract8(wo, n, eta, &wt);
            int8 ok2 = refract8(wo, ng, eta, &wt2);
            int8 use2 = ok1 & (l3_dot(wt, ng) >= 0.0f);
            reflected |= ~ok1 | (use2 & ~ok2);
            wt = l3_select(wt, wt2, use2);
            lane_float3 wr = reflect8(wo, n);
            wr = l3_select(wr, reflect8(wo, ng), l3_dot(wr, ng) <= 0.0f);
            lane_float3 gwi = l3_select(wt, wr, reflected);
            lane_float3 gweight = l3_select(l3_scale(albedo, 1.0f / (eta * eta)), l3_splat(1.0f), reflected);
            int8 straight = eta == 1.0f;
            gwi = l3_select(gwi, dir, straight);
            gweight = l3_select(gweight, albedo, straight);
            eta_scale = select(eta_scale, eta_scale * eta * eta, glass & ~reflected & ~straight);
            wi = l3_select(wi, gwi, glass);
            weight = l3_select(weight, gweight, glass);
            bpdf = select(bpdf, (float8)(1.0f), glass);
            cos_ng = l3_dot(ng, wi);
        }
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
