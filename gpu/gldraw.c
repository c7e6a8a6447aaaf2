/* gldraw.c - the GL passes every prt image goes through: a 32-bit float
 * render target (so images stay linear HDR radiance), the probe background
 * computed per pixel from the camera ray, Gouraud vertex colours with a depth
 * test, float read-back, and the tone-mapped blit for the viewer's window.
 * See gldraw.h. */
#include "gldraw.h"
#include "font6x13.h"
#include "probe.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *k_fullscreen_vs =
    "#version 330 core\n"
    "void main() {\n"
    "    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);\n"  /* one triangle covering the screen */
    "    gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);\n"
    "}\n";

/* The ray of pixel centre gl_FragCoord, as camera_ray: d = f + sx*R + sy*U with R, U pre-scaled by
 * tan(fov/2) (and the aspect). Latlong lookup per probe.h: u = 0.5 + atan2(x, -z)/2pi, v = acos(y)/pi. */
static const char *k_bg_fs =
    "#version 330 core\n"
    "uniform vec2 u_size;\n"
    "uniform vec3 u_fwd, u_right, u_up;\n"
    "uniform mat3 u_rot_t;\n"
    "uniform sampler2D u_probe;\n"
    "out vec4 o_color;\n"
    "void main() {\n"
    "    vec2 s = 2.0 * gl_FragCoord.xy / u_size - 1.0;\n"
    "    vec3 d = u_rot_t * normalize(u_fwd + s.x * u_right + s.y * u_up);\n"
    "    d = normalize(d);\n"
    "    float u = 0.5 + atan(d.x, -d.z) * 0.15915494309189535;\n"
    "    float v = acos(clamp(d.y, -1.0, 1.0)) * 0.3183098861837907;\n"
    "    o_color = vec4(max(texture(u_probe, vec2(u, v)).rgb, vec3(0.0)), 1.0);\n"
    "}\n";

static const char *k_vc_vs =
    "#version 330 core\n"
    "layout(location = 0) in vec3 a_pos;\n"
    "layout(location = 1) in vec3 a_col;\n"
    "layout(location = 4) in vec3 a_nrm;\n"
    "uniform mat4 u_mvp;\n"
    "out vec3 v_col;\n"
    "out vec3 v_pos;\n"
    "out vec3 v_nrm;\n"
    "void main() { v_col = a_col; v_pos = a_pos; v_nrm = a_nrm; gl_Position = u_mvp * vec4(a_pos, 1.0); }\n";

/* Multisampled, a fragment is shaded once per pixel at its centre, which may lie beyond the triangle on
 * a silhouette: the colours extrapolated there are clamped at 0 (radiance). Not `centroid`: llvmpipe
 * then evaluates off the centre on every edge a pixel straddles, the mesh's inner edges too, which
 * biases the Gouraud colours along them (the paper-phong sphere against a 1024-spp reference at
 * 400x300: rel_rmse 0.0472 with centroid, 0.0445 without). */
/* One-sided, as prt reference: a pixel whose interpolated normal faces away from the eye (the inside
 * of a body seen through a gap, a spout's mouth) is black, not its vertices' outside colour. */
static const char *k_vc_fs =
    "#version 330 core\n"
    "in vec3 v_col;\n"
    "in vec3 v_pos;\n"
    "in vec3 v_nrm;\n"
    "uniform vec3 u_eye;\n"
    "uniform int u_sided;\n"   /* 0: the mesh has no normals */
    "out vec4 o_color;\n"
    "void main() { o_color = vec4(u_sided == 0 || dot(v_nrm, u_eye - v_pos) > 0.0 ? max(v_col, 0.0) : vec3(0.0), 1.0); }\n";

/* Per-pixel texture: tex(u, 1 - v) * A + B (rows are uploaded top first: v = 1 is row 0, texture.h). */
static const char *k_tex_vs =
    "#version 330 core\n"
    "layout(location = 0) in vec3 a_pos;\n"
    "layout(location = 1) in vec3 a_col;\n"
    "layout(location = 2) in vec2 a_uv;\n"
    "layout(location = 3) in vec3 a_colb;\n"
    "layout(location = 4) in vec3 a_nrm;\n"
    "uniform mat4 u_mvp;\n"
    "out vec3 v_col;\n"
    "out vec3 v_colb;\n"
    "out vec2 v_uv;\n"
    "out vec3 v_pos;\n"
    "out vec3 v_nrm;\n"
    "void main() { v_col = a_col; v_colb = a_colb; v_uv = a_uv; v_pos = a_pos; v_nrm = a_nrm; gl_Position = u_mvp * vec4(a_pos, 1.0); }\n";

static const char *k_tex_fs =
    "#version 330 core\n"
    "in vec3 v_col;\n"
    "in vec3 v_colb;\n"
    "in vec2 v_uv;\n"
    "in vec3 v_pos;\n"
    "in vec3 v_nrm;\n"
    "uniform sampler2D u_tex;\n"
    "uniform vec3 u_eye;\n"
    "uniform int u_sided;\n"
    "out vec4 o_color;\n"
    "void main() {\n"
    "    vec3 c = texture(u_tex, vec2(v_uv.x, 1.0 - v_uv.y)).rgb * v_col + v_colb;\n"
    "    o_color = vec4(u_sided == 0 || dot(v_nrm, u_eye - v_pos) > 0.0 ? c : vec3(0.0), 1.0);\n"
    "}\n";

/* Exposure, clamp, sRGB (IEC 61966-2-1) like image_write's 8-bit output. */
static const char *k_present_fs =
    "#version 330 core\n"
    "uniform sampler2D u_img;\n"
    "uniform float u_scale;\n"
    "uniform vec2 u_win;\n"
    "out vec4 o_color;\n"
    "void main() {\n"
    "    vec2 uv = gl_FragCoord.xy / u_win;\n"
    "    vec3 c = clamp(texture(u_img, uv).rgb * u_scale, 0.0, 1.0);\n"
    "    vec3 lo = c * 12.92, hi = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;\n"
    "    o_color = vec4(mix(hi, lo, vec3(lessThanEqual(c, vec3(0.0031308)))), 1.0);\n"
    "}\n";

/* Compiles the passes; -1 with err. Free with gldraw_free. */
int gldraw_init(gldraw *d, const gl_api *gl, prt_error *err) {
    memset(d, 0, sizeof *d);
    d->gl = gl;
    d->samples = 1;
    if (!(d->prog_bg = glctx_program(gl, k_fullscreen_vs, k_bg_fs, "background", err))) return -1;
    if (!(d->prog_vc = glctx_program(gl, k_vc_vs, k_vc_fs, "vertex colours", err))) return -1;
    if (!(d->prog_present = glctx_program(gl, k_fullscreen_vs, k_present_fs, "present", err))) return -1;
    gl->GenVertexArrays(1, &d->vao_empty);
    return glctx_check(gl, "init", err);
}

/* Latlong RGB float texture of the probe: the image itself when it is latlong, else resampled. */
int gldraw_set_probe(gldraw *d, const prt_probe *p, prt_error *err) {
    const gl_api *gl = d->gl;
    d->has_probe = false;
    if (!p) return 0;
    GLint maxtex = 4096;
    gl->GetIntegerv(GL_MAX_TEXTURE_SIZE, &maxtex);
    const float *px = p->img.data;
    int w = p->img.w, h = p->img.h, c = p->img.c;
    float *tmp = NULL;
    bool latlong = p->layout == PROBE_LATLONG && w == 2 * h && w <= maxtex;
    if (!latlong) {
        h = p->img.h < 256 ? 256 : p->img.h;
        if (2 * h > maxtex) h = maxtex / 2;
        w = 2 * h;
        c = 3;
        tmp = prt_calloc((size_t)w * h * 3, sizeof(float), err);
        if (!tmp) return -1;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                /* Inverse of the latlong map of probe.h at texel centres. */
                float phi = ((x + 0.5f) / w - 0.5f) * 2.0f * (float)M_PI, th = (y + 0.5f) / h * (float)M_PI;
                float dir[3] = { sinf(th) * sinf(phi), cosf(th), -sinf(th) * cosf(phi) };
                probe_eval(p, dir, tmp + 3 * ((size_t)y * w + x));
            }
        px = tmp;
    }
    if (!d->probe_tex) gl->GenTextures(1, &d->probe_tex);
    gl->BindTexture(GL_TEXTURE_2D, d->probe_tex);
    gl->PixelStorei(GL_UNPACK_ALIGNMENT, 4);
    gl->TexImage2D(GL_TEXTURE_2D, 0, c == 4 ? GL_RGBA32F : GL_RGB32F, w, h, 0, c == 4 ? GL_RGBA : GL_RGB, GL_FLOAT, px);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    gl->BindTexture(GL_TEXTURE_2D, 0);
    free(tmp);
    if (glctx_check(gl, "probe texture upload", err)) return -1;
    d->has_probe = true;
    return 0;
}

/* Copies m's positions and triangles for gldraw_clip, with the bounding box of each run of
 * GLDRAW_CHUNK triangles; -1 with err (OOM). */
static int gldraw_keep_mesh(gldraw *d, const prt_mesh *m, prt_error *err) {
    free(d->pos);
    free(d->tris);
    free(d->chunk_box);
    const size_t nchunks = ((size_t)m->ntris + GLDRAW_CHUNK - 1) / GLDRAW_CHUNK;
    d->pos = prt_calloc((size_t)(m->nverts > 0 ? m->nverts : 1) * 3, sizeof(float), err);
    d->tris = d->pos ? prt_calloc((size_t)(m->ntris > 0 ? m->ntris : 1) * 3, sizeof(uint32_t), err) : NULL;
    d->chunk_box = d->tris ? prt_calloc((nchunks > 0 ? nchunks : 1) * 6, sizeof(float), err) : NULL;
    if (!d->chunk_box) return -1;
    if (m->nverts > 0) memcpy(d->pos, m->pos, (size_t)m->nverts * 3 * sizeof(float));
    if (m->ntris > 0) memcpy(d->tris, m->tris, (size_t)m->ntris * 3 * sizeof(uint32_t));
    for (size_t c = 0; c < nchunks; c++) {
        float *b = d->chunk_box + 6 * c;
        for (int k = 0; k < 3; k++) { b[k] = INFINITY; b[3 + k] = -INFINITY; }
        for (size_t i = 3 * c * GLDRAW_CHUNK; i < 3 * (size_t)m->ntris && i < 3 * (c + 1) * GLDRAW_CHUNK; i++)
            for (int k = 0; k < 3; k++) {
                const float x = m->pos[3 * (size_t)m->tris[i] + k];
                b[k] = x < b[k] ? x : b[k];
                b[3 + k] = x > b[3 + k] ? x : b[3 + k];
            }
    }
    return 0;
}

/* Uploads positions and triangles; -1 with err (OOM, GL out of memory). */
int gldraw_set_mesh(gldraw *d, const prt_mesh *m, prt_error *err) {
    const gl_api *gl = d->gl;
    free(d->scratch);
    d->scratch = prt_calloc((size_t)(m->nverts > 0 ? m->nverts : 1) * 3, sizeof(float), err);
    if (!d->scratch) return -1;
    d->nverts = m->nverts;
    d->ntris = m->ntris;
    if (m->nverts > 0) mesh_bounds(m, d->bmin, d->bmax);
    if (gldraw_keep_mesh(d, m, err)) return -1;
    if (!d->mesh_vao) {
        gl->GenVertexArrays(1, &d->mesh_vao);
        gl->GenBuffers(1, &d->mesh_pos);
        gl->GenBuffers(1, &d->mesh_col);
        gl->GenBuffers(1, &d->mesh_ebo);
        gl->GenBuffers(1, &d->mesh_nrm);
    }
    gl->BindVertexArray(d->mesh_vao);
    gl->BindBuffer(GL_ARRAY_BUFFER, d->mesh_pos);
    gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)m->nverts * 3 * sizeof(float), m->pos, GL_STATIC_DRAW);
    gl->EnableVertexAttribArray(0);
    gl->VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, 0);
    gl->BindBuffer(GL_ARRAY_BUFFER, d->mesh_col);
    gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)m->nverts * 3 * sizeof(float), NULL, GL_STREAM_DRAW);
    gl->EnableVertexAttribArray(1);
    gl->VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, 0);
    d->sided = m->nrm != NULL;
    gl->BindBuffer(GL_ARRAY_BUFFER, d->mesh_nrm);
    gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)m->nverts * 3 * sizeof(float), m->nrm, GL_STATIC_DRAW);
    gl->EnableVertexAttribArray(4);
    gl->VertexAttribPointer(4, 3, GL_FLOAT, GL_FALSE, 0, 0);
    gl->BindBuffer(GL_ELEMENT_ARRAY_BUFFER, d->mesh_ebo);
    gl->BufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)m->ntris * 3 * sizeof(uint32_t), m->tris, GL_STATIC_DRAW);
    gl->BindVertexArray(0);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    return glctx_check(gl, "mesh upload", err);
}

/* The sample count of later targets, clamped to [1, GL_MAX_SAMPLES]; returns it. */
int gldraw_set_samples(gldraw *d, int n) {
    GLint most = 1;
    d->gl->GetIntegerv(GL_MAX_SAMPLES, &most);
    d->samples = n < 1 ? 1 : n > most ? (most > 1 ? most : 1) : n;
    return d->samples;
}

/* The multisampled float target (colour and depth renderbuffers) at w x h and d->samples, made or
 * remade when the size or the count changed; -1 with err. */
static int gldraw_ms_target(gldraw *d, int w, int h, prt_error *err) {
    const gl_api *gl = d->gl;
    if (d->ms_fbo && d->ms_w == w && d->ms_h == h && d->ms_samples == d->samples) return 0;
    if (!d->ms_fbo) {
        gl->GenFramebuffers(1, &d->ms_fbo);
        gl->GenRenderbuffers(1, &d->ms_color);
        gl->GenRenderbuffers(1, &d->ms_depth);
    }
    gl->BindRenderbuffer(GL_RENDERBUFFER, d->ms_color);
    gl->RenderbufferStorageMultisample(GL_RENDERBUFFER, d->samples, GL_RGBA32F, w, h);
    gl->BindRenderbuffer(GL_RENDERBUFFER, d->ms_depth);
    gl->RenderbufferStorageMultisample(GL_RENDERBUFFER, d->samples, GL_DEPTH_COMPONENT32F, w, h);
    gl->BindRenderbuffer(GL_RENDERBUFFER, 0);
    gl->BindFramebuffer(GL_FRAMEBUFFER, d->ms_fbo);
    gl->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, d->ms_color);
    gl->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, d->ms_depth);
    GLenum st = gl->CheckFramebufferStatus(GL_FRAMEBUFFER);
    if (glctx_check(gl, "multisampled framebuffer allocation", err)) return -1;
    if (st != GL_FRAMEBUFFER_COMPLETE)
        return prt_fail(err, "GL float framebuffer %dx%d with %d samples incomplete (status 0x%x)", w, h, d->samples, st);
    d->ms_w = w;
    d->ms_h = h;
    d->ms_samples = d->samples;
    return 0;
}

/* Resolves the multisampled target into fbo (each pixel the mean of its samples: linear radiance
 * averaged, as a box filter over the pixel), once per drawing; nothing without samples. */
static void gldraw_resolve(gldraw *d) {
    const gl_api *gl = d->gl;
    if (d->resolved || !d->ms_fbo || d->ms_samples <= 1) return;
    gl->BindFramebuffer(GL_READ_FRAMEBUFFER, d->ms_fbo);
    gl->BindFramebuffer(GL_DRAW_FRAMEBUFFER, d->fbo);
    gl->BlitFramebuffer(0, 0, d->fbo_w, d->fbo_h, 0, 0, d->fbo_w, d->fbo_h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    gl->BindFramebuffer(GL_FRAMEBUFFER, d->fbo);
    d->resolved = true;
}

/* Sizes (if needed), binds and clears the float FBO (or the multisampled one); -1 with err. */
int gldraw_target(gldraw *d, int w, int h, prt_error *err) {
    const gl_api *gl = d->gl;
    if (w != d->fbo_w || h != d->fbo_h || !d->fbo) {
        GLint maxrb = 0;
        gl->GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &maxrb);
        if (w < 1 || h < 1 || w > maxrb || h > maxrb)
            return prt_fail(err, "image size %dx%d not supported by the GL implementation (max %d)", w, h, maxrb);
        if (!d->fbo) {
            gl->GenFramebuffers(1, &d->fbo);
            gl->GenTextures(1, &d->fbo_color);
            gl->GenRenderbuffers(1, &d->fbo_depth);
        }
        gl->BindTexture(GL_TEXTURE_2D, d->fbo_color);
        gl->TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, NULL);
        gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        gl->BindTexture(GL_TEXTURE_2D, 0);
        gl->BindRenderbuffer(GL_RENDERBUFFER, d->fbo_depth);
        gl->RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, w, h);
        gl->BindRenderbuffer(GL_RENDERBUFFER, 0);
        gl->BindFramebuffer(GL_FRAMEBUFFER, d->fbo);
        gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, d->fbo_color, 0);
        gl->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, d->fbo_depth);
        GLenum st = gl->CheckFramebufferStatus(GL_FRAMEBUFFER);
        if (glctx_check(gl, "framebuffer allocation", err)) return -1;
        if (st != GL_FRAMEBUFFER_COMPLETE)
            return prt_fail(err, "GL float framebuffer %dx%d incomplete (status 0x%x)", w, h, st);
        d->fbo_w = w;
        d->fbo_h = h;
    }
    bool ms = d->samples > 1;
    if (ms && gldraw_ms_target(d, w, h, err)) return -1;
    d->resolved = !ms;
    gl->BindFramebuffer(GL_FRAMEBUFFER, ms ? d->ms_fbo : d->fbo);
    gl->Viewport(0, 0, w, h);
    gl->ClearColor(0, 0, 0, 1);
    gl->ClearDepth(1.0);
    gl->DepthMask(GL_TRUE);
    gl->Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    return 0;
}

/* Column-major R^T of row-major R (identity for NULL). */
void gldraw_mat3_transpose_gl(const float R[9], float out[9]) {
    /* Row-major R read as column-major is R^T. */
    static const float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    memcpy(out, R ? R : I, 9 * sizeof(float));
}

/* Full-screen probe pass (camera_ray per pixel), no depth writes. */
void gldraw_background(gldraw *d, const prt_camera *cam, int w, int h, const float R[9]) {
    if (!d->has_probe) return;
    const gl_api *gl = d->gl;
    float f[3], r[3], u[3];
    camera_basis(cam, f, r, u);
    float fov = cam->fov_deg > 0 ? cam->fov_deg : 40.0f;
    float ty = tanf(fov * (float)M_PI / 360.0f), tx = ty * (float)w / (float)h;
    for (int i = 0; i < 3; i++) { r[i] *= tx; u[i] *= ty; }
    float rt[9];
    gldraw_mat3_transpose_gl(R, rt);
    gl->UseProgram(d->prog_bg);
    gl->Uniform2f(gl->GetUniformLocation(d->prog_bg, "u_size"), (float)w, (float)h);
    gl->Uniform3fv(gl->GetUniformLocation(d->prog_bg, "u_fwd"), 1, f);
    gl->Uniform3fv(gl->GetUniformLocation(d->prog_bg, "u_right"), 1, r);
    gl->Uniform3fv(gl->GetUniformLocation(d->prog_bg, "u_up"), 1, u);
    gl->UniformMatrix3fv(gl->GetUniformLocation(d->prog_bg, "u_rot_t"), 1, GL_FALSE, rt);
    gl->Uniform1i(gl->GetUniformLocation(d->prog_bg, "u_probe"), 0);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->BindTexture(GL_TEXTURE_2D, d->probe_tex);
    gl->Disable(GL_DEPTH_TEST);
    gl->DepthMask(GL_FALSE);
    gl->BindVertexArray(d->vao_empty);
    gl->DrawArrays(GL_TRIANGLES, 0, 3);
    gl->BindVertexArray(0);
    gl->DepthMask(GL_TRUE);
    gl->BindTexture(GL_TEXTURE_2D, 0);
}

/* The mesh bounds give the clip planes while their nearest corner lies at least this share of the
 * far plane ahead of the camera (a perspective depth buffer's step at distance z is about
 * z^2 / znear * 2^-24, so at most 100 * 2^-24 of the far distance then). */
#define GLDRAW_BOX_NEAR 0.01f

/* The camera's frame and view frustum: forward f, right r, up u, and the side planes as world
 * vectors a_k with a_k . (p - eye) >= 0 inside (x <= sx z, -x <= sx z, y <= sy z, -y <= sy z). */
typedef struct gldraw_frustum {
    float eye[3], f[3], a[4][3];
} gldraw_frustum;

/* cam's frustum on an image of aspect w/h, as camera_matrices projects it. */
static void gldraw_frustum_of(const prt_camera *cam, float aspect, gldraw_frustum *fr) {
    float r[3], u[3];
    camera_basis(cam, fr->f, r, u);
    const float fov = cam->fov_deg > 0 ? cam->fov_deg : 40.0f;
    const float sy = tanf(fov * (float)M_PI / 360.0f), sx = sy * aspect;
    for (int c = 0; c < 3; c++) {
        fr->eye[c] = cam->eye[c];
        fr->a[0][c] = sx * fr->f[c] - r[c];
        fr->a[1][c] = sx * fr->f[c] + r[c];
        fr->a[2][c] = sy * fr->f[c] - u[c];
        fr->a[3][c] = sy * fr->f[c] + u[c];
    }
}

/* A point relative to the eye: its depth z and plane values s[k] (inside all when every s[k] >= 0). */
typedef struct gldraw_pt {
    float z, s[4];
} gldraw_pt;

static gldraw_pt gldraw_point(const gldraw_frustum *fr, const float *p) {
    const float e[3] = { p[0] - fr->eye[0], p[1] - fr->eye[1], p[2] - fr->eye[2] };
    gldraw_pt q;
    q.z = e[0] * fr->f[0] + e[1] * fr->f[1] + e[2] * fr->f[2];
    for (int k = 0; k < 4; k++) q.s[k] = e[0] * fr->a[k][0] + e[1] * fr->a[k][1] + e[2] * fr->a[k][2];
    return q;
}

/* Clips polygon q[n] to s[k] >= 0 (Sutherland-Hodgman: every field is linear along an edge) into o;
 * returns its count (<= n + 1). */
static int gldraw_clip_poly(const gldraw_pt *q, int n, int k, gldraw_pt *o) {
    int m = 0;
    for (int i = 0; i < n; i++) {
        const gldraw_pt *a = &q[i], *b = &q[(i + 1) % n];
        if (a->s[k] >= 0) o[m++] = *a;
        if ((a->s[k] >= 0) != (b->s[k] >= 0)) {
            const float t = a->s[k] / (a->s[k] - b->s[k]);
            o[m].z = a->z + t * (b->z - a->z);
            for (int j = 0; j < 4; j++) o[m].s[j] = a->s[j] + t * (b->s[j] - a->s[j]);
            m++;
        }
    }
    return m;
}

/* Widens [*lo, *hi] by the depths of what of triangle t lies inside the frustum: all of it, none
 * of it (all three corners outside one plane), or the polygon left by clipping it to the planes. */
static void gldraw_tri_depths(const gldraw *d, const gldraw_frustum *fr, size_t t, float *lo, float *hi) {
    gldraw_pt q[2][7];
    unsigned all = 15, any = 0;
    for (int i = 0; i < 3; i++) {
        q[0][i] = gldraw_point(fr, d->pos + 3 * (size_t)d->tris[3 * t + i]);
        unsigned out = 0;
        for (int k = 0; k < 4; k++) out |= (unsigned)(q[0][i].s[k] < 0) << k;
        all &= out;
        any |= out;
    }
    if (all) return;
    int n = 3, cur = 0;
    for (int k = 0; k < 4 && n > 0; k++)
        if ((any >> k) & 1) { n = gldraw_clip_poly(q[cur], n, k, q[cur ^ 1]); cur ^= 1; }
    for (int i = 0; i < n; i++) {
        *lo = q[cur][i].z < *lo ? q[cur][i].z : *lo;
        *hi = q[cur][i].z > *hi ? q[cur][i].z : *hi;
    }
}

/* [lo, hi] of the linear function a . (p - eye) over box b (min, max). */
static void gldraw_box_range(const float *b, const float eye[3], const float a[3], float *lo, float *hi) {
    float c = 0, h = 0;
    for (int k = 0; k < 3; k++) {
        c += a[k] * (0.5f * (b[k] + b[3 + k]) - eye[k]);
        h += fabsf(a[k]) * 0.5f * (b[3 + k] - b[k]);
    }
    *lo = c - h;
    *hi = c + h;
}

/* Chunk c's box against the frustum: -1 outside one side plane, 1 inside all four, 0 across;
 * [*zmin, *zmax] its depths. */
static int gldraw_chunk_side(const gldraw *d, const gldraw_frustum *fr, size_t c, float *zmin, float *zmax) {
    const float *b = d->chunk_box + 6 * c;
    int side = 1;
    for (int k = 0; k < 4; k++) {
        float smin, smax;
        gldraw_box_range(b, fr->eye, fr->a[k], &smin, &smax);
        if (smax < 0) return -1;
        if (smin < 0) side = 0;
    }
    gldraw_box_range(b, fr->eye, fr->f, zmin, zmax);
    return side;
}

/* A depth range [*lo, *hi] holding every point of the mesh inside cam's view frustum (aspect w/h),
 * with the nearest and farthest to within a chunk's box: the chunks whose boxes are inside all
 * four side planes add their boxes' depths, then those across a plane their triangles clipped to
 * the frustum, unless their boxes' depths are inside the range already. False when nothing is in
 * view. */
static bool gldraw_view_depths(const gldraw *d, const prt_camera *cam, float aspect, float *lo, float *hi) {
    if (!d->chunk_box || d->ntris <= 0) return false;
    gldraw_frustum fr;
    gldraw_frustum_of(cam, aspect, &fr);
    const size_t nchunks = ((size_t)d->ntris + GLDRAW_CHUNK - 1) / GLDRAW_CHUNK;
    float zmin, zmax;
    *lo = INFINITY;
    *hi = -INFINITY;
    for (size_t c = 0; c < nchunks; c++)
        if (gldraw_chunk_side(d, &fr, c, &zmin, &zmax) == 1) {
            *lo = zmin < *lo ? zmin : *lo;
            *hi = zmax > *hi ? zmax : *hi;
        }
    for (size_t c = 0; c < nchunks; c++)
        if (gldraw_chunk_side(d, &fr, c, &zmin, &zmax) == 0 && (zmin < *lo || zmax > *hi))
            for (size_t t = c * GLDRAW_CHUNK; t < (size_t)d->ntris && t < (c + 1) * GLDRAW_CHUNK; t++)
                gldraw_tri_depths(d, &fr, t, lo, hi);
    return *hi > 0;
}

/* Near/far planes bracketing the mesh along the view direction. The bounds' corners bracket it
 * cheaply while the box lies ahead of the camera. A floor several times the model's size reaches
 * under and behind a camera that frames the model: the nearest corner is then behind the eye and
 * says nothing about the nearest visible point, and a near plane at the 1e-5 of the far one that
 * guards against geometry at the eye leaves a depth step of about 2 cm at the model (z^2 / znear *
 * 2^-24), so surfaces a few millimetres behind others (a tail's inner shell, an eyeball behind
 * its lids) show through as dark speckles. There the planes come from the triangles clipped to the
 * view frustum: the nearest and farthest points that can reach a pixel. */
void gldraw_clip(const gldraw *d, const prt_camera *cam, float aspect, float *znear, float *zfar) {
    float f[3], r[3], u[3];
    camera_basis(cam, f, r, u);
    float dmin = INFINITY, dmax = -INFINITY;
    for (int c = 0; c < 8; c++) {
        float p[3] = { c & 1 ? d->bmax[0] : d->bmin[0], c & 2 ? d->bmax[1] : d->bmin[1], c & 4 ? d->bmax[2] : d->bmin[2] };
        float z = (p[0] - cam->eye[0]) * f[0] + (p[1] - cam->eye[1]) * f[1] + (p[2] - cam->eye[2]) * f[2];
        if (z < dmin) dmin = z;
        if (z > dmax) dmax = z;
    }
    if (!(dmax > 0) || !isfinite(dmax)) { *znear = 0.01f; *zfar = 100.0f; return; }
    float fa = dmax * 1.05f;   /* relative only: an absolute margin would clip a scene 1e-12 across */
    float ne = dmin * 0.95f, lo, hi;
    if (ne < GLDRAW_BOX_NEAR * fa && gldraw_view_depths(d, cam, aspect, &lo, &hi)) {
        fa = hi * 1.05f;
        ne = lo * 0.95f;
    }
    if (ne < fa * 1e-5f) ne = fa * 1e-5f;
    *znear = ne;
    *zfar = fa;
}

/* proj * view (column-major). */
void gldraw_mvp(const gldraw *d, const prt_camera *cam, int w, int h, float mvp[16]) {
    float zn, zf, view[16], proj[16];
    gldraw_clip(d, cam, (float)w / (float)h, &zn, &zf);
    camera_matrices(cam, (float)w / (float)h, zn, zf, view, proj);
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 4; r++) {
            float s = 0;
            for (int k = 0; k < 4; k++) s += proj[k * 4 + r] * view[c * 4 + k];
            mvp[c * 4 + r] = s;
        }
}

/* Uploads sanitized colours and draws the mesh with the depth test; -1 with err. */
int gldraw_vertex_colors(gldraw *d, const prt_camera *cam, int w, int h, const float *rgb, prt_error *err) {
    const gl_api *gl = d->gl;
    if (d->ntris == 0) return 0;
    for (size_t i = 0; i < (size_t)d->nverts * 3; i++) d->scratch[i] = isfinite(rgb[i]) ? rgb[i] : 0.0f;
    gl->BindBuffer(GL_ARRAY_BUFFER, d->mesh_col);
    gl->BufferSubData(GL_ARRAY_BUFFER, 0, (GLsizeiptr)d->nverts * 3 * sizeof(float), d->scratch);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    float mvp[16];
    gldraw_mvp(d, cam, w, h, mvp);
    gl->UseProgram(d->prog_vc);
    gl->UniformMatrix4fv(gl->GetUniformLocation(d->prog_vc, "u_mvp"), 1, GL_FALSE, mvp);
    gl->Uniform3fv(gl->GetUniformLocation(d->prog_vc, "u_eye"), 1, cam->eye);
    gl->Uniform1i(gl->GetUniformLocation(d->prog_vc, "u_sided"), d->sided);
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthFunc(GL_LESS);
    gl->BindVertexArray(d->mesh_vao);
    gl->DrawElements(GL_TRIANGLES, d->ntris * 3, GL_UNSIGNED_INT, 0);
    gl->BindVertexArray(0);
    gl->Disable(GL_DEPTH_TEST);
    return glctx_check(gl, "drawing the mesh", err);
}

/* One float RGB texture: linear, repeat (texture.h's sampling). */
static GLuint tex_upload(const gl_api *gl, int w, int h, const float *lin) {
    GLuint t = 0;
    gl->GenTextures(1, &t);
    gl->BindTexture(GL_TEXTURE_2D, t);
    gl->PixelStorei(GL_UNPACK_ALIGNMENT, 4);
    gl->TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, w, h, 0, GL_RGB, GL_FLOAT, lin);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    gl->BindTexture(GL_TEXTURE_2D, 0);
    return t;
}

/* Triangles sorted by texture (their first vertex's material's; 0 none) into tris, the groups into d. */
static void tex_groups(gldraw *d, const prt_scene *sc, uint32_t *tris) {
    const prt_mesh *m = &sc->mesh;
    int n = sc->ntextures + 1, count[SCENE_MAX_TEXTURES + 1] = { 0 };
    for (int t = 0; t < m->ntris; t++) count[sc->material_texture[m->mat[m->tris[3 * (size_t)t]]]]++;
    d->ngroups = n;
    for (int g = 0, at = 0; g < n; at += count[g], g++) d->group_first[g] = at, d->group_count[g] = count[g];
    int at[SCENE_MAX_TEXTURES + 1];
    memcpy(at, d->group_first, sizeof(int) * (size_t)n);
    for (int t = 0; t < m->ntris; t++) {
        int g = sc->material_texture[m->mat[m->tris[3 * (size_t)t]]];
        memcpy(tris + 3 * (size_t)at[g]++, m->tris + 3 * (size_t)t, 3 * sizeof(uint32_t));
    }
}

int gldraw_set_textures(gldraw *d, const prt_scene *sc, prt_error *err) {
    const gl_api *gl = d->gl;
    const prt_mesh *m = &sc->mesh;
    if (sc->ntextures < 1 || !m->uv || !m->mat || m->nverts != d->nverts) return 0;
    uint32_t *tris = prt_calloc(3 * (size_t)m->ntris, sizeof *tris, err);
    if (!tris || !(d->prog_tex = glctx_program(gl, k_tex_vs, k_tex_fs, "textured colours", err))) { free(tris); return -1; }
    tex_groups(d, sc, tris);
    const float white[3] = { 1, 1, 1 };
    d->tex[0] = tex_upload(gl, 1, 1, white);
    for (int t = 0; t < sc->ntextures; t++) d->tex[t + 1] = tex_upload(gl, sc->textures[t].w, sc->textures[t].h, sc->textures[t].lin);
    gl->GenVertexArrays(1, &d->tex_vao);
    gl->GenBuffers(1, &d->mesh_uv);
    gl->GenBuffers(1, &d->mesh_colb);
    gl->GenBuffers(1, &d->tex_ebo);
    gl->BindVertexArray(d->tex_vao);
    const GLuint bufs[5] = { d->mesh_pos, d->mesh_col, d->mesh_uv, d->mesh_colb, d->mesh_nrm };
    for (int a = 0; a < 5; a++) {
        gl->BindBuffer(GL_ARRAY_BUFFER, bufs[a]);
        if (a == 2) gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)m->nverts * 2 * sizeof(float), m->uv, GL_STATIC_DRAW);
        if (a == 3) gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)m->nverts * 3 * sizeof(float), NULL, GL_STREAM_DRAW);
        gl->EnableVertexAttribArray((GLuint)a);
        gl->VertexAttribPointer((GLuint)a, a == 2 ? 2 : 3, GL_FLOAT, GL_FALSE, 0, 0);
    }
    gl->BindBuffer(GL_ELEMENT_ARRAY_BUFFER, d->tex_ebo);
    gl->BufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)m->ntris * 3 * sizeof(uint32_t), tris, GL_STATIC_DRAW);
    gl->BindVertexArray(0);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    free(tris);
    return glctx_check(gl, "texture upload", err);
}

/* Uploads n floats of src (non-finite -> 0) into buffer b through d's scratch. */
static void upload_colors(gldraw *d, GLuint b, const float *src) {
    const gl_api *gl = d->gl;
    for (size_t i = 0; i < (size_t)d->nverts * 3; i++) d->scratch[i] = isfinite(src[i]) ? src[i] : 0.0f;
    gl->BindBuffer(GL_ARRAY_BUFFER, b);
    gl->BufferSubData(GL_ARRAY_BUFFER, 0, (GLsizeiptr)d->nverts * 3 * sizeof(float), d->scratch);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
}

int gldraw_textured_colors(gldraw *d, const prt_camera *cam, int w, int h, const float *A, const float *B, prt_error *err) {
    const gl_api *gl = d->gl;
    if (d->ntris == 0) return 0;
    if (!d->prog_tex) return prt_fail(err, "drawing textures: none uploaded");
    upload_colors(d, d->mesh_col, A);
    upload_colors(d, d->mesh_colb, B);
    float mvp[16];
    gldraw_mvp(d, cam, w, h, mvp);
    gl->UseProgram(d->prog_tex);
    gl->UniformMatrix4fv(gl->GetUniformLocation(d->prog_tex, "u_mvp"), 1, GL_FALSE, mvp);
    gl->Uniform1i(gl->GetUniformLocation(d->prog_tex, "u_tex"), 0);
    gl->Uniform3fv(gl->GetUniformLocation(d->prog_tex, "u_eye"), 1, cam->eye);
    gl->Uniform1i(gl->GetUniformLocation(d->prog_tex, "u_sided"), d->sided);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthFunc(GL_LESS);
    gl->BindVertexArray(d->tex_vao);
    for (int g = 0; g < d->ngroups; g++) {
        if (!d->group_count[g]) continue;
        gl->BindTexture(GL_TEXTURE_2D, d->tex[g]);
        gl->DrawElements(GL_TRIANGLES, d->group_count[g] * 3, GL_UNSIGNED_INT, (const void *)((size_t)d->group_first[g] * 3 * sizeof(uint32_t)));
    }
    gl->BindTexture(GL_TEXTURE_2D, 0);
    gl->BindVertexArray(0);
    gl->Disable(GL_DEPTH_TEST);
    return glctx_check(gl, "drawing the textured mesh", err);
}

/* Reads the FBO into a new top-first RGB image (caller frees); -1 with err. */
int gldraw_read(gldraw *d, prt_image *out, prt_error *err) {
    const gl_api *gl = d->gl;
    int w = d->fbo_w, h = d->fbo_h;
    float *rgba = prt_calloc((size_t)w * h * 4, sizeof(float), err);
    if (!rgba) return -1;
    if (image_alloc(out, w, h, 3, err)) { free(rgba); return -1; }
    gldraw_resolve(d);
    gl->BindFramebuffer(GL_FRAMEBUFFER, d->fbo);
    gl->ReadBuffer(GL_COLOR_ATTACHMENT0);
    gl->PixelStorei(GL_PACK_ALIGNMENT, 4);
    gl->ReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, rgba);
    if (glctx_check(gl, "reading the image back", err)) { free(rgba); image_free(out); return -1; }
    /* GL rows are bottom-first; prt images are top-first. */
    for (int y = 0; y < h; y++) {
        const float *src = rgba + (size_t)(h - 1 - y) * w * 4;
        float *dst = out->data + (size_t)y * w * 3;
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) {
                float v = src[4 * x + c];
                dst[3 * x + c] = isfinite(v) ? v : 0.0f;
            }
    }
    free(rgba);
    return 0;
}

/* Tone-mapped blit of the FBO to the window framebuffer. */
void gldraw_present(gldraw *d, int win_w, int win_h, float exposure_stops) {
    const gl_api *gl = d->gl;
    gldraw_resolve(d);
    gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
    gl->Viewport(0, 0, win_w, win_h);
    gl->Disable(GL_DEPTH_TEST);
    gl->UseProgram(d->prog_present);
    gl->Uniform1i(gl->GetUniformLocation(d->prog_present, "u_img"), 0);
    gl->Uniform1f(gl->GetUniformLocation(d->prog_present, "u_scale"), exp2f(exposure_stops));
    gl->Uniform2f(gl->GetUniformLocation(d->prog_present, "u_win"), (float)win_w, (float)win_h);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->BindTexture(GL_TEXTURE_2D, d->fbo_color);
    gl->BindVertexArray(d->vao_empty);
    gl->DrawArrays(GL_TRIANGLES, 0, 3);
    gl->BindVertexArray(0);
    gl->BindTexture(GL_TEXTURE_2D, 0);
}

/* Deletes every GL object (context current) and zeroes d. */
void gldraw_free(gldraw *d) {
    const gl_api *gl = d->gl;
    if (!gl) return;
    if (d->prog_bg) gl->DeleteProgram(d->prog_bg);
    if (d->prog_vc) gl->DeleteProgram(d->prog_vc);
    if (d->prog_tex) gl->DeleteProgram(d->prog_tex);
    for (int t = 0; t <= SCENE_MAX_TEXTURES; t++)
        if (d->tex[t]) gl->DeleteTextures(1, &d->tex[t]);
    if (d->tex_vao) {
        gl->DeleteVertexArrays(1, &d->tex_vao);
        gl->DeleteBuffers(1, &d->mesh_uv);
        gl->DeleteBuffers(1, &d->mesh_colb);
        gl->DeleteBuffers(1, &d->tex_ebo);
    }
    if (d->prog_present) gl->DeleteProgram(d->prog_present);
    if (d->vao_empty) gl->DeleteVertexArrays(1, &d->vao_empty);
    if (d->probe_tex) gl->DeleteTextures(1, &d->probe_tex);
    if (d->fbo) {
        gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
        gl->DeleteFramebuffers(1, &d->fbo);
        gl->DeleteTextures(1, &d->fbo_color);
        gl->DeleteRenderbuffers(1, &d->fbo_depth);
    }
    if (d->ms_fbo) {
        gl->DeleteFramebuffers(1, &d->ms_fbo);
        gl->DeleteRenderbuffers(1, &d->ms_color);
        gl->DeleteRenderbuffers(1, &d->ms_depth);
    }
    if (d->mesh_vao) {
        gl->DeleteVertexArrays(1, &d->mesh_vao);
        gl->DeleteBuffers(1, &d->mesh_pos);
        gl->DeleteBuffers(1, &d->mesh_col);
        gl->DeleteBuffers(1, &d->mesh_nrm);
        gl->DeleteBuffers(1, &d->mesh_ebo);
    }
    free(d->scratch);
    free(d->pos);
    free(d->tris);
    free(d->chunk_box);
    memset(d, 0, sizeof *d);
}

/* ---------------------------------------------------------------- text */


static const char *k_text_vs =
    "#version 330 core\n"
    "layout(location = 0) in vec4 a;\n" /* x, y in pixels from the top-left; u, v in atlas texels */
    "uniform vec2 u_win;\n"
    "out vec2 v_uv;\n"
    "void main() { v_uv = a.zw; gl_Position = vec4(2.0 * a.x / u_win.x - 1.0, 1.0 - 2.0 * a.y / u_win.y, 0.0, 1.0); }\n";

static const char *k_text_fs =
    "#version 330 core\n"
    "uniform sampler2D u_font;\n"
    "uniform vec4 u_color;\n"
    "uniform int u_box;\n"
    "in vec2 v_uv;\n"
    "out vec4 o_color;\n"
    "void main() {\n"
    "    float a = u_box != 0 ? 1.0 : texelFetch(u_font, ivec2(v_uv), 0).r;\n"
    "    if (a < 0.5) discard;\n"
    "    o_color = u_color;\n"
    "}\n";

/* Uploads the font atlas and compiles the text shader; -1 with err. */
int gltext_init(gltext *t, const gl_api *gl, prt_error *err) {
    memset(t, 0, sizeof *t);
    t->gl = gl;
    if (!(t->prog = glctx_program(gl, k_text_vs, k_text_fs, "text", err))) return -1;
    /* Atlas: the 95 glyphs side by side, one byte per pixel. */
    uint8_t atlas[FONT_H][95 * FONT_W];
    for (int g = 0; g < 95; g++)
        for (int r = 0; r < FONT_H; r++)
            for (int c = 0; c < FONT_W; c++) atlas[r][g * FONT_W + c] = (k_font[g][r] & (0x80 >> c)) ? 255 : 0;
    gl->GenTextures(1, &t->tex);
    gl->BindTexture(GL_TEXTURE_2D, t->tex);
    gl->PixelStorei(GL_UNPACK_ALIGNMENT, 1);
    gl->TexImage2D(GL_TEXTURE_2D, 0, GL_R8, 95 * FONT_W, FONT_H, 0, GL_RED, GL_UNSIGNED_BYTE, atlas);
    gl->PixelStorei(GL_UNPACK_ALIGNMENT, 4);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl->BindTexture(GL_TEXTURE_2D, 0);
    gl->GenVertexArrays(1, &t->vao);
    gl->GenBuffers(1, &t->vbo);
    gl->BindVertexArray(t->vao);
    gl->BindBuffer(GL_ARRAY_BUFFER, t->vbo);
    gl->EnableVertexAttribArray(0);
    gl->VertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 0, 0);
    gl->BindVertexArray(0);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    return glctx_check(gl, "text init", err);
}

/* Appends one quad (two triangles) of pixel rectangle (x0,y0)-(x1,y1) with atlas rectangle (u0,v0)-(u1,v1). */
static float *quad(float *p, float x0, float y0, float x1, float y1, float u0, float v0, float u1, float v1) {
    const float q[6][4] = { { x0, y0, u0, v0 }, { x1, y0, u1, v0 }, { x1, y1, u1, v1 },
                            { x0, y0, u0, v0 }, { x1, y1, u1, v1 }, { x0, y1, u0, v1 } };
    memcpy(p, q, sizeof q);
    return p + 24;
}

/* Draws text over the window framebuffer; returns the height used in pixels. */
int gltext_draw(gltext *t, int win_w, int win_h, int x, int y, int scale, const char *text) {
    const gl_api *gl = t->gl;
    if (scale < 1) scale = 1;
    int n = (int)strlen(text), lines = 1, cols = 0, maxcols = 0;
    for (int i = 0; i < n; i++) {
        if (text[i] == '\n') { lines++; cols = 0; }
        else if (++cols > maxcols) maxcols = cols;
    }
    if (n + 1 > t->cap) {
        float *nv = realloc(t->verts, sizeof(float) * 24 * (size_t)(n + 1));
        if (!nv) return 0;
        t->verts = nv;
        t->cap = n + 1;
    }
    const int lh = (FONT_H + 1) * scale, pad = 4;
    float *p = t->verts;
    int cx = x, cy = y, glyphs = 0;
    for (int i = 0; i < n; i++) {
        unsigned char c = (unsigned char)text[i];
        if (c == '\n') { cx = x; cy += lh; continue; }
        if (c < 32 || c > 126) c = '?';
        float u0 = (float)((c - 32) * FONT_W);
        p = quad(p, (float)cx, (float)cy, (float)(cx + FONT_W * scale), (float)(cy + FONT_H * scale), u0, 0,
                 u0 + FONT_W, FONT_H);
        glyphs++;
        cx += FONT_W * scale;
    }
    float box[24];
    quad(box, (float)(x - pad), (float)(y - pad), (float)(x + maxcols * FONT_W * scale + pad),
         (float)(y + lines * lh + pad), 0, 0, 0, 0);
    gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
    gl->Viewport(0, 0, win_w, win_h);
    gl->Disable(GL_DEPTH_TEST);
    gl->Enable(GL_BLEND);
    gl->BlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    gl->UseProgram(t->prog);
    gl->Uniform2f(gl->GetUniformLocation(t->prog, "u_win"), (float)win_w, (float)win_h);
    gl->Uniform1i(gl->GetUniformLocation(t->prog, "u_font"), 0);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->BindTexture(GL_TEXTURE_2D, t->tex);
    gl->BindVertexArray(t->vao);
    gl->BindBuffer(GL_ARRAY_BUFFER, t->vbo);
    GLint lbox = gl->GetUniformLocation(t->prog, "u_box"), lcol = gl->GetUniformLocation(t->prog, "u_color");
    /* Box. */
    gl->BufferData(GL_ARRAY_BUFFER, sizeof box, box, GL_STREAM_DRAW);
    gl->Uniform1i(lbox, 1);
    gl->Uniform4fv(lcol, 1, (const float[4]){ 0, 0, 0, 0.55f });
    gl->DrawArrays(GL_TRIANGLES, 0, 6);
    /* Shadow, then the glyphs. */
    gl->Uniform1i(lbox, 0);
    for (int pass = 0; pass < 2 && glyphs; pass++) {
        if (pass == 0)
            for (int i = 0; i < glyphs * 6; i++) { t->verts[4 * i] += 1; t->verts[4 * i + 1] += 1; }
        else
            for (int i = 0; i < glyphs * 6; i++) { t->verts[4 * i] -= 1; t->verts[4 * i + 1] -= 1; }
        gl->BufferData(GL_ARRAY_BUFFER, sizeof(float) * 24 * (size_t)glyphs, t->verts, GL_STREAM_DRAW);
        gl->Uniform4fv(lcol, 1, pass == 0 ? (const float[4]){ 0, 0, 0, 1 } : (const float[4]){ 1, 1, 0.92f, 1 });
        gl->DrawArrays(GL_TRIANGLES, 0, glyphs * 6);
    }
    gl->BindVertexArray(0);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    gl->BindTexture(GL_TEXTURE_2D, 0);
    gl->Disable(GL_BLEND);
    gl->UseProgram(0);
    return lines * lh + 2 * pad;
}

/* Deletes the text objects (context current) and zeroes t. */
void gltext_free(gltext *t) {
    const gl_api *gl = t->gl;
    if (gl) {
        if (t->prog) gl->DeleteProgram(t->prog);
        if (t->tex) gl->DeleteTextures(1, &t->tex);
        if (t->vao) gl->DeleteVertexArrays(1, &t->vao);
        if (t->vbo) gl->DeleteBuffers(1, &t->vbo);
    }
    free(t->verts);
    memset(t, 0, sizeof *t);
}
