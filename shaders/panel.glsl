// A text panel (texture drawn with Pillow, sRGB): the HUD and the study's pages and questions.
// Screen space (a rectangle in NDC), or, with u_world, a quad fixed in the world seen through
// each eye's view-projection (in a headset, panels stay put while the head moves).
#ifdef VERTEX_SHADER
in vec2 in_corner;  // [0, 1]^2
uniform vec4 u_rect;  // NDC x0, y0, x1, y1
uniform bool u_world;
uniform mat4 u_view_proj;
uniform vec3 u_center;  // world, metres
uniform vec3 u_half_right;  // half the panel's width along its right
uniform vec3 u_half_up;  // half its height along its up
out vec2 v_uv;
void main() {
    v_uv = vec2(in_corner.x, 1.0 - in_corner.y);
    if (u_world) {
        vec2 s = 2.0 * in_corner - 1.0;
        gl_Position = u_view_proj * vec4(u_center + s.x * u_half_right + s.y * u_half_up, 1.0);
    } else {
        gl_Position = vec4(mix(u_rect.xy, u_rect.zw, in_corner), 0.0, 1.0);
    }
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
