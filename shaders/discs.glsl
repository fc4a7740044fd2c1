// The overhead view's agent discs, one instanced draw (triangle fan per disc).
#ifdef VERTEX_SHADER
in vec2 in_unit;        // unit circle (fan centre first)
in vec3 in_disc;        // per instance: x, y, radius
in vec4 in_disc_color;  // per instance
uniform mat3 u_map;
out vec4 v_color;
void main() {
    vec2 p = in_disc.xy + in_unit * in_disc.z;
    v_color = in_disc_color;
    gl_Position = vec4((u_map * vec3(p, 1.0)).xy, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT_SHADER
in vec4 v_color;
out vec4 f_color;
void main() {
    f_color = v_color;
}
#endif
