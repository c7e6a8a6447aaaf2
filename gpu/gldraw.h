/* gldraw.h - GL drawing passes shared by the offscreen renderer (render.c), the
 * GLSL runtime (glrt.c) and the viewer (cli_view.c): the float render target,
 * the probe background, Gouraud vertex colours, read-back and the tone-mapped
 * blit to a window.
 *
 * Usage (with a current context, see glctx.h):
 *     gldraw gd;
 *     if (gldraw_init(&gd, &ctx->gl, &err)) ...
 *     gldraw_set_mesh(&gd, &mesh, &err);  gldraw_set_probe(&gd, probe, &err);
 *     gldraw_set_samples(&gd, 4);                     // optional: multisampled targets
 *     gldraw_target(&gd, w, h, &err);                // float FBO, bound and cleared
 *     gldraw_background(&gd, &cam, w, h, R);          // probe seen through the camera
 *     gldraw_vertex_colors(&gd, &cam, w, h, rgb, &err);
 *     gldraw_read(&gd, &img, &err);                    // linear RGB floats, top row first
 *     gldraw_free(&gd);
 *
 * The background is drawn as one full-screen triangle whose fragment shader
 * builds each pixel's view ray exactly as camera_ray does (render.h) and looks
 * the probe up in a latitude-longitude texture (the probe itself when it is
 * latlong, else resampled once with probe_eval), rotated by R^T so that a
 * light at d appears at R d (as probe_to_cube rotates it). Then the mesh is drawn
 * with the depth test. No culling: a floor seen from below is still drawn.
 *
 * Antialiasing: with samples > 1 the passes draw into a multisampled float target (colour and depth
 * renderbuffers) that gldraw_read and gldraw_present resolve into the float FBO first: each pixel the
 * mean of its samples' linear radiance (a box filter over the pixel), so read-back images stay
 * linear HDR. Fragments are shaded once per pixel (a caller may ask for per-sample shading, glrt.c);
 * silhouettes, where the samples of one pixel see different surfaces, are what it smooths.
 *
 * Ownership: all GL objects belong to the gldraw; gldraw_free deletes them
 * (the context must be current). Errors: -1 with one line in err. */
#ifndef PRT_GLDRAW_H
#define PRT_GLDRAW_H
#include "glctx.h"
#include "render.h"
#include "scene.h"

/* Triangles per box of gldraw_clip's view test: a box wholly inside or outside the view settles its
 * run without touching the triangles. */
#define GLDRAW_CHUNK 32

typedef struct gldraw {
    const gl_api *gl;
    GLuint prog_bg, prog_vc, prog_present, vao_empty;
    GLuint probe_tex;
    bool has_probe;
    GLuint fbo, fbo_color, fbo_depth;
    int fbo_w, fbo_h;
    int samples;                 /* samples per pixel the next targets take (gldraw_set_samples; 1: none) */
    GLuint ms_fbo, ms_color, ms_depth; /* samples > 1: the multisampled target drawn into, resolved into fbo */
    int ms_w, ms_h, ms_samples;
    bool resolved;               /* fbo holds what was drawn into the multisampled target */
    GLuint mesh_vao, mesh_pos, mesh_col, mesh_ebo, mesh_nrm;
    bool sided;                  /* the mesh has normals: pixels whose normal faces away are black */
    int nverts, ntris;
    float bmin[3], bmax[3];      /* mesh bounds, for the clip planes */
    float *pos;                  /* [3*nverts] positions, [3*ntris] triangles and the boxes of each run of */
    uint32_t *tris;              /* GLDRAW_CHUNK triangles ([6] each: min, max) kept on the CPU: the clip */
    float *chunk_box;            /* planes of a view the bounds do not bracket (gldraw_clip) */
    float *scratch;              /* [3*nverts] sanitized colours */
    /* textures (gldraw_set_textures): triangles grouped by texture, its coordinates, the second colour */
    GLuint prog_tex, tex_vao, mesh_uv, mesh_colb, tex_ebo;
    GLuint tex[SCENE_MAX_TEXTURES + 1];   /* [0]: white, for untextured triangles */
    int ngroups, group_first[SCENE_MAX_TEXTURES + 1], group_count[SCENE_MAX_TEXTURES + 1];
} gldraw;

int gldraw_init(gldraw *d, const gl_api *gl, prt_error *err);
/* Uploads the probe as a latlong texture (NULL: black background). */
int gldraw_set_probe(gldraw *d, const prt_probe *p, prt_error *err);
/* Uploads positions and triangles (colours come per draw). */
int gldraw_set_mesh(gldraw *d, const prt_mesh *m, prt_error *err);
/* Antialiasing of the targets gldraw_target makes from now on: n samples per pixel (multisampling;
 * 0 or 1: one sample at the pixel centre), at most what the context allows (GL_MAX_SAMPLES).
 * Returns the count that will be used. */
int gldraw_set_samples(gldraw *d, int n);
/* Makes sure the float FBO is w x h, binds it (with samples: the multisampled target it resolves
 * from), sets the viewport and clears colour and depth. */
int gldraw_target(gldraw *d, int w, int h, prt_error *err);
/* Draws the probe (or nothing when none is set) behind everything; R row-major 3x3 or NULL. */
void gldraw_background(gldraw *d, const prt_camera *cam, int w, int h, const float R[9]);
/* Near and far clip distances for cam on an image of aspect w/h: those of the mesh bounds when
 * they lie well ahead of the camera, else those of the triangles in view (gldraw.c says why). */
void gldraw_clip(const gldraw *d, const prt_camera *cam, float aspect, float *znear, float *zfar);
/* proj * view (column-major) for cam on a w x h target, clip planes from gldraw_clip. */
void gldraw_mvp(const gldraw *d, const prt_camera *cam, int w, int h, float mvp[16]);
/* Uploads rgb[3*nverts] (non-finite -> 0) and draws the mesh with Gouraud colours. */
int gldraw_vertex_colors(gldraw *d, const prt_camera *cam, int w, int h, const float *rgb, prt_error *err);
/* Textures (texture.h): uploads sc's textures (linear RGB floats, bilinear, repeat: texture_sample's
 * rule), its mesh's coordinates and its triangles grouped by texture (none: 0, nothing made).
 * Call after gldraw_set_mesh with the same mesh. -1 with err. */
int gldraw_set_textures(gldraw *d, const prt_scene *sc, prt_error *err);
/* Draws the mesh with per-pixel colour tex(uv) * A + B: A[3*nverts] the part a texture multiplies
 * (untextured vertices: white), B[3*nverts] the rest, both Gouraud (needs gldraw_set_textures). */
int gldraw_textured_colors(gldraw *d, const prt_camera *cam, int w, int h, const float *A, const float *B, prt_error *err);
/* Reads the FBO's colour into out (allocated here, 3 channels, top row first, finite); a multisampled
 * target is resolved first: each pixel the mean of its samples' linear radiance. */
int gldraw_read(gldraw *d, prt_image *out, prt_error *err);
/* Draws the FBO's colour into the default framebuffer (win_w x win_h) with exposure 2^stops,
 * clamp and sRGB encoding (the same tone curve as image_write's PNG output). */
void gldraw_present(gldraw *d, int win_w, int win_h, float exposure_stops);
void gldraw_free(gldraw *d);

/* On-screen text in the 6x13 X11 "Fixed" bitmap font (font6x13.h), drawn with GL over the
 * current framebuffer: a translucent dark box, then white glyphs with a 1-pixel shadow. */
typedef struct gltext {
    const gl_api *gl;
    GLuint prog, tex, vao, vbo;
    float *verts;       /* scratch: 6 vertices x 4 floats per glyph */
    int cap;            /* glyphs the scratch holds */
} gltext;
int gltext_init(gltext *t, const gl_api *gl, prt_error *err);
/* Draws text ('\n' separates lines) with its top-left corner at (x, y) pixels from the top-left of a
 * win_w x win_h framebuffer, glyphs scaled by an integer factor. Returns the height drawn in pixels. */
int gltext_draw(gltext *t, int win_w, int win_h, int x, int y, int scale, const char *text);
void gltext_free(gltext *t);

/* Row-major 3x3 R -> column-major GL mat3 of R^T (what the background shader wants). */
void gldraw_mat3_transpose_gl(const float R[9], float out[9]);
#endif
