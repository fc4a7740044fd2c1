// Full-screen passes: the red-cyan anaglyph from a side-by-side stereo
// image (u_mode 0), and the comfort vignette while moving (u_mode 1).
#ifdef VERTEX_SHADER
in vec2 in_corner;  // [0, 1]^2
out vec2 v_uv;
void main() {
    v_uv = in_corner;
    gl_Position = vec4(in_corner * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT_SHADER
in vec2 v_uv;
out vec4 f_color;
uniform int u_mode;
uniform sampler2D u_stereo;   // left eye in the left half, right eye in the right half
uniform float u_strength;     // vignette: 0 = none, 1 = strongest

void main() {
    if (u_mode == 0) {
        vec3 l = texture(u_stereo, vec2(v_uv.x * 0.5, v_uv.y)).rgb;
        vec3 r = texture(u_stereo, vec2(0.5 + v_uv.x * 0.5, v_uv.y)).rgb;
        // Half-colour anaglyph: the left eye's luminance in red, the right eye in green/blue.
        float ll = dot(l, vec3(0.299, 0.587, 0.114));
        f_color = vec4(ll, r.g, r.b, 1.0);
    } else {
        float d = length(v_uv - 0.5) * 2.0;
        float inner = mix(1.2, 0.45, u_strength);
        float a = smoothstep(inner, inner + 0.35, d) * u_strength;
        f_color = vec4(0.0, 0.0, 0.0, a);
    }
}
#endif
