// lift/fresnel.glsl: Fresnel reflectance of unpolarised light (average of s and p).
#ifndef LIFT_FRESNEL_GLSL
#define LIFT_FRESNEL_GLSL

// Dielectric interface, exact. eta = n_t / n_i, the index on the side opposite the normal's
// side over the index on the normal's side; cos_theta_i < 0 means the incident direction is
// on the other side, so the interface is seen with 1 / eta. Total internal reflection -> 1.
float fresnel_dielectric(float cos_theta_i, float eta) {
    cos_theta_i = clamp(cos_theta_i, -1.0, 1.0);
    if (cos_theta_i < 0.0) {
        eta = 1.0 / eta;
        cos_theta_i = -cos_theta_i;
    }
    float sin2_t = (1.0 - cos_theta_i * cos_theta_i) / (eta * eta);
    if (sin2_t >= 1.0) return 1.0;
    float cos_t = sqrt(max(0.0, 1.0 - sin2_t));
    float r_parl = (eta * cos_theta_i - cos_t) / (eta * cos_theta_i + cos_t);
    float r_perp = (cos_theta_i - eta * cos_t) / (cos_theta_i + eta * cos_t);
    return 0.5 * (r_parl * r_parl + r_perp * r_perp);
}

// Conductor with complex index eta + i k (relative to the outside medium), exact, per
// channel. Closed form of the Fresnel equations with a^2 + b^2 = |(eta + ik)^2 - sin^2|.
vec3 fresnel_conductor(float cos_theta_i, vec3 eta, vec3 k) {
    float c = clamp(cos_theta_i, 0.0, 1.0);
    float cos2 = c * c;
    float sin2 = 1.0 - cos2;
    vec3 eta2 = eta * eta;
    vec3 k2 = k * k;
    vec3 t0 = eta2 - k2 - vec3(sin2);
    vec3 a2_plus_b2 = sqrt(max(t0 * t0 + 4.0 * eta2 * k2, vec3(0.0)));
    vec3 a = sqrt(max(0.5 * (a2_plus_b2 + t0), vec3(0.0)));
    vec3 t1 = a2_plus_b2 + vec3(cos2);
    vec3 t2 = 2.0 * c * a;
    vec3 r_s = (t1 - t2) / max(t1 + t2, vec3(1e-20));
    vec3 t3 = cos2 * a2_plus_b2 + vec3(sin2 * sin2);
    vec3 t4 = t2 * sin2;
    vec3 r_p = r_s * (t3 - t4) / max(t3 + t4, vec3(1e-20));
    return clamp(0.5 * (r_p + r_s), 0.0, 1.0);
}

// Schlick's approximation with normal-incidence reflectance f0.
vec3 fresnel_schlick(float cos_theta, vec3 f0) {
    float m = 1.0 - clamp(cos_theta, 0.0, 1.0);
    float m2 = m * m;
    return f0 + (vec3(1.0) - f0) * (m2 * m2 * m);
}

#endif
