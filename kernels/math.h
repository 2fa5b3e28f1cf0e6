// Small vector helpers and the numeric traps of spawning rays.
#ifndef CLRENDER_MATH_H
#define CLRENDER_MATH_H

#define PI_F 3.14159265358979323846f
#define INV_PI_F 0.31830988618379067154f

float max_component(float3 v) { return fmax(v.x, fmax(v.y, v.z)); }

float luminance(float3 c) { return dot(c, (float3)(0.2126f, 0.7152f, 0.0722f)); }

bool is_black(float3 c) { return c.x == 0.0f && c.y == 0.0f && c.z == 0.0f; }

// Branchless orthonormal basis around a unit vector (Duff et al. 2017, "Building an Orthonormal
// Basis, Revisited"): no normalisation, no special case except the sign.
void make_basis(float3 n, float3* t, float3* b) {
    float s = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (s + n.z);
    float c = n.x * n.y * a;
    *t = (float3)(1.0f + s * n.x * n.x * a, s * c, -s * n.x);
    *b = (float3)(c, s + n.y * n.y * a, -n.y);
}

float3 to_world(float3 v, float3 n) {
    float3 t, b;
    make_basis(n, &t, &b);
    return v.x * t + v.y * b + v.z * n;
}

// sin and cos of 2*pi*u for u in [0, 1). PoCL's sin/cos are slow (tens of M/s); a minimax
// polynomial on [-pi/4, pi/4] after octant reduction is exact to ~1 ulp for sampling purposes.
void sincos_2pi(float u, float* s, float* c) {
    float x = u * 4.0f;                      // quarter turns
    float q = floor(x + 0.5f);
    float r = (x - q) * (0.5f * PI_F);       // in [-pi/4, pi/4]
    float r2 = r * r;
    float sr = r * (1.0f + r2 * (-1.6666667e-1f + r2 * (8.3333310e-3f + r2 * -1.9840874e-4f)));
    float cr = 1.0f + r2 * (-0.5f + r2 * (4.1666638e-2f + r2 * (-1.3888378e-3f + r2 * 2.4760495e-5f)));
    int quadrant = ((int)q) & 3;
    float sv = (quadrant & 1) ? cr : sr;
    float cv = (quadrant & 1) ? sr : cr;
    *s = (quadrant & 2) ? -sv : sv;
    *c = ((quadrant + 1) & 2) ? -cv : cv;
}

// Offset a ray origin off a surface by a few ulps of its own magnitude, so that spawned rays do
// not re-hit their surface at any scale or distance from the origin (Waechter and Binder,
// "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems ch. 6).
// n is the geometric normal on the side the ray leaves from.
float3 offset_ray_origin(float3 p, float3 n) {
    const float origin = 1.0f / 32.0f;
    const float float_scale = 1.0f / 65536.0f;
    const float int_scale = 256.0f;
    int3 of = convert_int3(int_scale * n);
    float3 p_int = (float3)(as_float(as_int(p.x) + (p.x < 0.0f ? -of.x : of.x)),
                            as_float(as_int(p.y) + (p.y < 0.0f ? -of.y : of.y)),
                            as_float(as_int(p.z) + (p.z < 0.0f ? -of.z : of.z)));
    return (float3)(fabs(p.x) < origin ? p.x + float_scale * n.x : p_int.x,
                    fabs(p.y) < origin ? p.y + float_scale * n.y : p_int.y,
                    fabs(p.z) < origin ? p.z + float_scale * n.z : p_int.z);
}

#endif
