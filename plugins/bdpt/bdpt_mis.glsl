// bdpt_mis.glsl: the MIS weight of strategy (s, t), by the ratio walk of pbrt-v3 (sec. 16.3.4)
// generalised to any power. Among the strategies that can make the same path, strategy k's
// density over this one's is a product of pdf_rev / pdf_fwd ratios, one per vertex that
// changes subpath. The weight is 1 / (1 + sum over other strategies of ratio^mis_power):
// the balance heuristic for power 1, Veach's power heuristic for 2.
//
// The join changes four reverse densities (the two joined vertices and their predecessors):
// the caller computes them for this path and passes them in. For s = 1 the light vertex was
// sampled afresh by sample_light_point, whose density the caller passes as light_pdf, and
// light_delta says whether it is a distant light. A delta light can't be reached by a camera
// subpath, so the strategy s = 0 gets no share (pbrt-v3's IsDeltaLight test); a light
// vertex itself is never delta in the sense of `delta` (a BSDF's delta lobe).

float mis_term(float ratio) {
    if (mis_power == 2.0) return ratio * ratio;  // the default: spare the pow
    return ratio > 0.0 ? pow(ratio, mis_power) : 0.0;
}

// A zero density belongs to a delta lobe; it cancels between numerator and denominator.
float nonzero(float pdf) { return pdf != 0.0 ? pdf : 1.0; }

float mis_weight(int s, int t, float pt_rev, float pt_minus_rev, float qs_rev, float qs_minus_rev, float light_pdf,
                 bool light_delta) {
    if (only_s >= 0) return 1.0;  // study mode: one strategy alone, unweighted
    if (s + t == 2) return 1.0;   // an emitter seen directly: only the camera subpath makes it
    float others = 0.0;

    // ---- The join slides towards the camera: the light subpath takes camera vertices t-1 .. 1 ----
    float ratio = 1.0;
    for (int i = t - 1; i > 0; --i) {
        float rev = i == t - 1 ? pt_rev : (i == t - 2 ? pt_minus_rev : bdpt_path[i].pdf_rev);
        ratio *= nonzero(rev) / nonzero(bdpt_path[i].pdf_fwd);
        bool delta_here = i != t - 1 && vertex_delta(i);  // the joined vertex is never delta
        if (!delta_here && !vertex_delta(i - 1)) others += mis_term(ratio);
    }

    // ---- The join slides towards the light: the camera subpath takes light vertices s-1 .. 0 ----
    ratio = 1.0;
    if (s >= 2) light_delta = vertex_kind(BDPT_LIGHT_BASE) == VERTEX_DISTANT;
    for (int i = s - 1; i >= 0; --i) {
        int k = BDPT_LIGHT_BASE + i;
        float rev = i == s - 1 ? qs_rev : (i == s - 2 ? qs_minus_rev : bdpt_path[k].pdf_rev);
        float fwd = s == 1 ? light_pdf : bdpt_path[k].pdf_fwd;
        ratio *= nonzero(rev) / nonzero(fwd);
        bool delta_here = i != s - 1 && vertex_delta(k);
        bool delta_before = i > 0 ? vertex_delta(k - 1) : light_delta;
        if (!delta_here && !delta_before) others += mis_term(ratio);
    }
    return 1.0 / (1.0 + others);
}
