// Dispatch over material kinds. Only the kinds compiled in by feature defines appear here.
#ifndef CLRENDER_BSDF_H
#define CLRENDER_BSDF_H

typedef struct {
    float3 wi;
    float3 weight;   // f * |cos| / pdf_w
    float pdf_w;     // 0: no sample (the path ends)
    bool delta;
} BsdfSample;

bool material_is_delta(const Material* m) { return false; }

float3 eval_bsdf(const Material* m, const SurfacePoint* sp, float3 wo, float3 wi) {
    return eval_diffuse(m->color.xyz, sp, wi);
}

float sample_bsdf_pdf(const Material* m, const SurfacePoint* sp, float3 wo, float3 wi) {
    return sample_diffuse_pdf(sp, wi);
}

BsdfSample sample_bsdf(const Material* m, const SurfacePoint* sp, float3 wo, Rng* rng) {
    BsdfSample bs;
    bs.delta = false;
    bs.wi = sample_diffuse(sp, rng_float2(rng));
    bs.pdf_w = sample_diffuse_pdf(sp, bs.wi);
    // For cosine sampling f * cos / pdf is the albedo itself; dividing would only add rounding.
    bs.weight = bs.pdf_w > 0.0f ? m->color.xyz : (float3)(0.0f);
    return bs;
}

#endif
