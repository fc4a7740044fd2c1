// The overhead debug view (2D): filled triangles and lines in ground
// coordinates, mapped to NDC by u_map (paper Fig. 1 right, Fig. 4).
#ifdef VERTEX_SHADER
in vec2 in_pos;
in vec4 in_color;
uniform mat3 u_map;
out vec4 v_color;
void main() {
    vec3 p = u_map * vec3(in_pos, 1.0);
    v_color = in_color;
    gl_Position = vec4(p.xy, 0.0, 1.0);
}
#endif

#ifdef FRAGMENT_SHADER
in vec4 v_color;
out vec4 f_color;
void main() {
    f_color = v_color;
}
#endif
