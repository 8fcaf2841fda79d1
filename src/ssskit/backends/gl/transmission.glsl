// ssskit: the per-pixel body of the transmittance pass (ssskit.backends.transmission_plan, steps 1-5; Jimenez et
// al. 2010's translucency shadow map): ONE source, wrapped as the GLSL 4.30 compute shader the gl backend runs
// (transmission.comp) and as the GLSL ES 3.00 fragment shader browsers run (transmission.frag);
// ssskit.backends.gl.transmission joins them.
//
// The wrapper provides u_shadow_size (ivec2, the map's texels) and load_shadow(i, j) (the map's depth in mm at
// texel (i, j), row j as the map's array rows). The plan's tables (the generated block) come first.

bool finite(float v) { return !(isinf(v) || isnan(v)); }

// The pass at one pixel (transmission_plan steps 1-5): its slot s, light-space position (map texel x, y;
// depth along the light, mm), N . L and the light's irradiance; the map through load_shadow(i, j).
vec3 transmission_texel(int s, vec3 uvz, float ndl, vec3 light) {
    vec3 res = vec3(0.0);
    if (s <= 0) return res;
    float px = uvz.x - 0.5;
    float py = uvz.y - 0.5;
    if (!(finite(px) && finite(py))) return res;
    float fi = floor(px), fj = floor(py);
    float fx = px - fi, fy = py - fj;
    int i0 = int(fi), j0 = int(fj);
    float acc = 0.0, wsum = 0.0;
    for (int q = 0; q < 4; ++q) {  // step 1
        int di = q & 1, dj = q >> 1;
        float wgt = (di == 1 ? fx : 1.0 - fx) * (dj == 1 ? fy : 1.0 - fy);
        int ii = i0 + di, jj = j0 + dj;
        if (wgt > 0.0 && ii >= 0 && ii < u_shadow_size.x && jj >= 0 && jj < u_shadow_size.y) {
            float d = load_shadow(ii, jj);
            if (finite(d)) { acc += wgt * d; wsum += wgt; }
        }
    }
    if (!(wsum > 0.0)) return res;
    float t = uvz.z - acc / wsum;  // step 2
    if (!(finite(t) && t > BIAS)) return res;
    if (NORMAL[s] > 0.0) t *= clamp(-ndl, 0.0, 1.0);  // step 2: along the surface normal
    float e = clamp(WRAP[s] - ndl, 0.0, 1.0);  // step 3
    float u = SCALE[s] * t;
#if HAS_LUT
    if (LUT_SLOT[s] == 1) {  // step 4 of an unreal slot: UE's optical depth, its shadow-mask encoding, the table
        float od = clamp(OD_PER_MM[s] * u + OD_OFFSET[s], 0.15, OD_MAX) + 0.25;
        float enc = 1.0 - od / OD_MAX;
        float x = (1.0 - enc * enc) * float(LUT_N - 1);
        float fi = min(floor(x), float(LUT_N - 2));
        int li = int(fi);
        float f = x - fi;
        for (int ch = 0; ch < 3; ++ch) {  // steps 4-5
            int base = (s * 3 + ch) * LUT_N + li;
            float tr = (1.0 - f) * LUT[base] + f * LUT[base + 1];
            res[ch] = tr * (light[ch] * e);
        }
        return res;
    }
#endif
    for (int ch = 0; ch < 3; ++ch) {  // steps 4-5
        float tr = 0.0;
        for (int k = 0; k < NTERMS; ++k) {
            int i = (s * 3 + ch) * NTERMS + k;
            tr += COEF_A[i] * exp(-COEF_B[i] * u - COEF_C[i] * u * u);
        }
        res[ch] = tr * (light[ch] * e);
    }
    return res;
}
