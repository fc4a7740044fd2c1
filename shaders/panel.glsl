// A text panel (texture drawn with Pillow, sRGB) as a screen-space quad: the HUD and the
// study's pages and questions.
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
// The target encodes linear values to sRGB itself (an sRGB swapchain): decode the image first.
uniform bool u_linear_target;
void main() {
    vec4 c = texture(u_tex, v_uv);
    f_color = vec4(u_linear_target ? pow(c.rgb, vec3(2.2)) : c.rgb, c.a);
}
#endif
