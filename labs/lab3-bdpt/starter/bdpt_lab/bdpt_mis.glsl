// bdpt_mis.glsl (step 3): the MIS weight of strategy (s, t), pbrt-v3's ratio walk (sec. 16.3.4)
// generalised to any power and summed as the subpaths are traced, so that a join reads two
// vertices of each subpath rather than walking both. Among the strategies that can make the
// same path, strategy k's density over this one's is a product of ratios rev_i / fwd_i, one per
// vertex that changes subpath (rev_i: vertex i's density were it sampled from the other side).
// The weight is 1 / (1 + sum over other strategies of ratio^mis_power): the balance heuristic
// for power 1, Veach's power heuristic for 2. Since (a b)^p = a^p b^p, each side's sum obeys a
// recursion over its subpath (as in Georgiev et al. 2012's vertex connection and merging).
//
// A join changes the reverse densities of the two joined vertices and of their predecessors;
// the caller computes them. Further back, rev_i is fixed once vertex i+1 has sampled its BSDF,
// and vertex k carries the sum over i <= k - 2 (rho_i = (rev_i / fwd_i)^mis_power):
//     mis_sum_k = [neither i = k-1 nor k-2 is delta] + rho_{k-2} mis_sum_{k-1},
// which next_mis_sum forms while the walk goes on. Joining at vertex k (one side), the
// strategies that move the join past k, k-1, ... add
//     rho'_k ([k-1 not delta] + rho'_{k-1} mis_sum_k)
// (mis_side), the primes marking the densities the join changed. A delta vertex (a BSDF's
// delta lobe) can't be joined, so strategies that would need to are left out: their density
// ratios still pass through, a zero density counting as 1 (`nonzero`, it cancels out). The
// camera side ends at z1 (no strategy hits the pinhole): z1 starts with mis_sum 0. The light
// side ends at y0, which s = 0 could only have hit if the light is not a delta in direction
// (pbrt-v3's IsDeltaLight): y1 starts with mis_sum 1, or 0 under a distant light.

float mis_term(float ratio) {
    if (mis_power == 2.0) return ratio * ratio;  // the default: spare the pow
    return ratio > 0.0 ? pow(ratio, mis_power) : 0.0;
}

// A zero density belongs to a delta lobe; it cancels between numerator and denominator.
float nonzero(float pdf) { return pdf != 0.0 ? pdf : 1.0; }

float mis_ratio(float rev, float fwd) { return mis_term(nonzero(rev) / nonzero(fwd)); }

// YOUR TURN (step 3): the two recursions of the header, in code. Until they are written
// every strategy gets weight 1, and the image counts each path once per strategy that made it.

// The mis_sum of the vertex after the one that just sampled its BSDF (`delta`: by a delta lobe),
// whose predecessor's reverse density is now rev_before (that predecessor: delta_before, fwd_before).
float next_mis_sum(float mis_sum, bool delta, bool delta_before, float rev_before, float fwd_before) {
    return 0.0;
}

// The sum over the strategies that move the join along one subpath, past its joined vertex
// (reverse density rev, forward fwd, the vertex's mis_sum) and the vertex before it (delta_before,
// rev_before, fwd_before).
float mis_side(float rev, float fwd, float mis_sum, bool delta_before, float rev_before, float fwd_before) {
    return 0.0;
}

float mis_weight(float camera_side, float light_side) {
    if (only_s >= 0) return 1.0;  // study mode: one strategy alone, unweighted
    return 1.0 / (1.0 + camera_side + light_side);
}
