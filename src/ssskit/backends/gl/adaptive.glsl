// ssskit: the per-pixel body of the guiding phase of the variance-guided adaptive sampler (Xie et al. 2020,
// Sec. 4.1, Fig. 8): ONE source, wrapped as the GLSL 4.30 compute shader the gl backend runs (adaptive.comp)
// and as the GLSL ES 3.00 fragment shader browsers run (adaptive.frag); ssskit.backends.gl.adaptive joins them.
//
// The wrapper provides u_size, load_hist(q) (vec4: n_bar, mu, sigma^2, m), load_mask(q) (float, > 0 with SSS),
// load_motion(q) (HAS_MOTION), load_valid(q) (HAS_VALID), load_rgb(q) and load_count(q) (UPDATE: this frame's
// Burley result and sample counts). The plan's constants (the generated block) come first.

// The pass at pixel p (row 0 at the top of the image, as ssskit's arrays): the next sample count, and in
// h_out the history (with UPDATE: the new one).
int adaptive_texel(ivec2 p, out vec4 h_out) {
    // step 1: the nearest fetch of the previous history, no rejection; off-screen or invalid: none
    bool ok = true;
    ivec2 q = p;
#if HAS_VALID
    ok = load_valid(p) != 0u;
#endif
#if HAS_MOTION
    vec2 mv = load_motion(p);
    vec2 f = floor(vec2(p) + 0.5 + mv);
    if (any(lessThan(f, vec2(0.0))) || any(greaterThanEqual(f, vec2(u_size)))) ok = false;
    else q = ivec2(f);
#endif
    vec4 h = ok ? load_hist(q) : vec4(0.0);
    bool inside = load_mask(p) > 0.0;
#if UPDATE
    // step 2: Eqs. 8, 6, 9, with M' = 1 (Eq. 16) and sigma^2 = sigma0^2 (Eq. 17) without history
    float v = 0.0;
    if (inside) {
        vec3 c = load_rgb(p);
        float y = max(c.r * 0.2126 + c.g * 0.7152 + c.b * 0.0722, 0.0);  // BT.709 luminance
        v = GAMMA_ONE != 0 ? y : pow(y, INV_GAMMA);                        // gamma-corrected (Sec. 4.1.2)
    }
    bool had = h.w > 0.0;
    float a = had ? ALPHA : 1.0;
    float b = 1.0 - a;
    float d = v - h.y;                                  // S - C
    float n_bar = b * h.x + a * float(load_count(p));   // Eq. 8
    float mu = a * d + h.y;                             // Eq. 6
    float var = had ? (a * d * d + h.z) * b : SIGMA0_SQ;   // Eq. 9; Eq. 17
    h = inside ? vec4(n_bar, mu, var, 1.0) : vec4(0.0);
#endif
    // steps 3-4: n_hat = n_bar (var + kappa (k - 1) spread) / sigma0^2 (Eqs. 13-15), clamped to the budget
    int n = 0;
    if (inside) {
        float nb = h.x * h.w;
#if VARIANCE
        float spread = h.z - SIGMA0_SQ;
#else
        float spread = sqrt(h.z) - SIGMA0;
#endif
        float nh = ((spread * SPREAD_SCALE + h.z) * nb) / SIGMA0_SQ;
        if (h.z == SIGMA0_SQ) {
            // Eq. 17's variance: n_hat = n_bar exactly; the CPU's float64 estimate of the float32-stored
            // sigma0^2 gives n_bar (1 + delta), delta of the sign of float32(sigma0^2) - sigma0^2 (S0_ROUNDS_UP)
            nh = (S0_ROUNDS_UP != 0 && nb > 0.0 && nb == floor(nb)) ? nb + 0.5 : nb;
        }
        if (isnan(nh) || nh > float(B_MAX)) n = B_MAX;
        else if (nh <= float(B_MIN)) n = B_MIN;
        else n = int(ceil(nh));
    }
    h_out = h;
    return n;
}
