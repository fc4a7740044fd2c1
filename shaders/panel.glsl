// A text panel (texture drawn with Pillow) as a screen-space quad.
#ifdef VERTEX_SHADER
in vec2 in_corner;  // [0, 1]^2
uniform vec4 u_rect;  // NDC x0, y0, x1, y1
out vec2 v_uv;
void main() {
    v_uv = vec2(in_corner.x, 1.0 - in_corner.y);
    gl_Position = vec4(mix(u_rect.xy, u_rect.zw, in_corner), 0.0, 1.0);
}
#endif

#ifdef FRAGMENT_SHADER
in vec2 v_uv;
out vec4 f_color;
uniform sampler2D u_tex;
void main() {
    f_color = texture(u_tex, v_uv);
}
#endif
