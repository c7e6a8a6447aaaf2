/* cli_view.c - `prt view`, the interactive relighting viewer, and `prt glbench`,
 * GL versus CPU runtime frame rates beside the paper's Table II.
 *
 * The viewer is a GLFW window drawn entirely through the GLSL runtime's float
 * target (glrt.h): with the GL backend the GPU does both the light change
 * (sparse T x L) and the view change (per-pixel view maps); with the CPU
 * backend relight.c computes per-vertex colours that glrt draws (the paper's
 * CPU path). Either way the image is tone-mapped (exposure, clamp, sRGB) onto
 * the window, and the on-screen text (6x13 bitmap font) shows the frame time,
 * the last light-change and view-change times, the probe, K and the exposure.
 * A light change happens only when the probe or its rotation changes; orbiting
 * is a view change only, exactly the split the paper times.
 *
 * Scripted use (tests, screenshots): --frames N renders N frames and exits,
 * --screenshot OUT.png saves the last one (linear float target written with
 * image_write, the same tone curve `prt render` uses for PNG). */
#include "cli.h"
#include "cli_args.h"
#include "glrt.h"
#include "gldraw.h"
#include "image.h"
#include "probe.h"
#include "prtfile.h"
#include "relight.h"
#include "render.h"
#include "transfer.h"
#include "vec3.h"
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#define VIEW_MAX_PROBES 64

static const char *k_view = "view";

static const char *k_keys =
    "  mouse left drag          orbit the camera around its target\n"
    "  mouse right/middle drag  pan\n"
    "  mouse wheel              zoom (dolly toward the target)\n"
    "  shift or ctrl + left drag  rotate the lighting (yaw, pitch): a light change\n"
    "  1 .. 9                   switch to probe 1..9\n"
    "  n / p                    next / previous probe\n"
    "  + / -                    exposure up / down half a stop\n"
    "  K / k                    use more / fewer BRDF terms\n"
    "  b                        toggle the GL runtime / the CPU runtime\n"
    "  v                        GL view model: per-pixel view maps / per-vertex (as the CPU)\n"
    "  d                        direct only vs with bounces (files precomputed with --keep-direct)\n"
    "  s                        screenshot (PNG, current exposure)\n"
    "  r                        reset camera and light rotation\n"
    "  h or ?                   show / hide this help on screen\n"
    "  q or Esc                 quit\n";

/* Prints the usage, options and keys. */
static void view_help(void) {
    printf("usage: prt view FILE.prt --probe PROBE [--probe P2 ...] [--probes DIR] [options]\n"
           "\n"
           "Interactive relighting: a window showing the scene relit under the probe, with\n"
           "the frame rate and the last light-change and view-change times on screen.\n"
           "\n"
           "  --probe PROBE          a light probe (repeatable; keys 1-9 / n / p switch)\n"
           "  --probes DIR           every .exr, .hdr and .pfm probe in DIR\n"
           "  --layout L             probe layout: latlong, angular, vcross, hcross (default: auto)\n"
           "  --size WxH             window size (default 1024x768)\n"
           "  --camera EX,EY,EZ[,TX,TY,TZ[,FOV]]  initial camera (default: framed as prt render)\n"
           "  --light-rotation Y[,P] initial light rotation in degrees (yaw about +y, then pitch)\n"
           "  --exposure E           exposure in stops (default 0)\n"
           "  --terms K              BRDF terms used (default: all)\n"
           "  --backend gl|cpu       runtime at start (default gl)\n"
           "  --view-model pixel|vertex  GL view model (default pixel)\n"
           "  --threads T            CPU runtime threads (default: all cores)\n"
           "  --frames N             render N frames, then exit (no interaction)\n"
           "  --screenshot OUT.png   with --frames: save the last frame; otherwise the S key's file\n"
           "  --window-shot OUT.png  with --frames: also save the window as displayed, text included\n"
           "  --keys CHARS           with --frames: press these keys, one before each frame from the second\n"
           "\n"
           "keys:\n%s", k_keys);
}

typedef struct viewer {
    const char *file;
    prt_data d;
    prt_probe probes[VIEW_MAX_PROBES];
    char names[VIEW_MAX_PROBES][128];
    int nprobes, probe;
    glctx *ctx;
    glrt *rt;
    gltext text;
    relight_ctx *rc;
    float *rgb;
    float (*L)[4];
    prt_camera cam, cam0;
    float lyaw, lpitch, lyaw0, lpitch0, R[9];
    bool gl, vertex_model, help, quit, direct;
    int kmax, kfile, nthreads;
    float exposure;
    bool light_dirty, g_dirty_gl, g_dirty_cpu, probe_dirty, view_dirty, present_dirty;
    double lightvec_ms, light_ms, view_ms, frame_ms;
    const char *light_backend, *view_backend;
    char status[4300];
    double status_until, title_at;
    int fbw, fbh;
    int drag;               /* 0 none, 1 orbit, 2 pan, 3 light */
    double mx, my;
    const char *shot_path, *window_shot, *keys;
    bool window_shot_now;
    int shots;
} viewer;

/* Shows msg on screen for a few seconds and on stderr. */
static void set_status(viewer *v, const char *msg) {
    snprintf(v->status, sizeof v->status, "%s", msg);
    v->status_until = prt_now() + 4.0;
    fprintf(stderr, "prt view: %s\n", msg);
    v->present_dirty = true;
}

/* Light rotation matrix through probe_parse_rotation, so the convention is exactly `prt render --light-rotation`. */
static void update_rotation(viewer *v) {
    char s[64];
    snprintf(s, sizeof s, "%.6f,%.6f", v->lyaw, v->lpitch);
    if (probe_parse_rotation(s, v->R) != 0) {
        static const float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
        memcpy(v->R, I, sizeof I);
    }
}

static bool rotated(const viewer *v) { return v->lyaw != 0 || v->lpitch != 0; }

/* Light change: light vector from the rotated probe, then T x L on the current backend (the other
 * backend's K-vectors are refreshed when it is switched to). */
static int light_change(viewer *v, prt_error *err) {
    if (v->light_dirty) {
        double t0 = prt_now();
        free(v->L);
        v->L = NULL;
        float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
        if (cube) { probe_to_cube(&v->probes[v->probe], CUBE_RES, rotated(v) ? v->R : NULL, 0, cube); v->L = transfer_light_vector(&v->d, cube); }
        free(cube);
        if (!v->L) return prt_fail(err, "out of memory");
        v->lightvec_ms = 1e3 * (prt_now() - t0);
        v->light_dirty = false;
        v->g_dirty_gl = v->g_dirty_cpu = true;
        glrt_set_background_rotation(v->rt, rotated(v) ? v->R : NULL);
    }
    if (v->probe_dirty) {
        if (glrt_set_background(v->rt, &v->probes[v->probe], rotated(v) ? v->R : NULL, err)) return -1;
        v->probe_dirty = false;
    }
    if (v->gl && v->g_dirty_gl) {
        if (glrt_set_light(v->rt, (const float (*)[4])v->L, err)) return -1;
        glrt_timing t;
        glrt_get_timing(v->rt, &t);
        v->light_ms = t.light_ms;
        v->light_backend = "GL";
        v->g_dirty_gl = false;
    } else if (!v->gl && v->g_dirty_cpu) {
        double t0 = prt_now();
        relight_set_light(v->rc, (const float (*)[4])v->L);
        v->light_ms = 1e3 * (prt_now() - t0);
        v->light_backend = "CPU";
        v->g_dirty_cpu = false;
    }
    return 0;
}

/* View change: relit image of the current camera into the float target. */
static int view_change(viewer *v, prt_error *err) {
    double t0 = prt_now();
    if (v->gl) {
        if (glrt_draw(v->rt, &v->cam, v->fbw, v->fbh, v->kmax, err)) return -1;
    } else {
        relight_view(v->rc, v->cam.eye, v->kmax, v->rgb);
        if (glrt_draw_vertex_colors(v->rt, &v->cam, v->fbw, v->fbh, v->rgb, err)) return -1;
    }
    v->view_ms = 1e3 * (prt_now() - t0);
    v->view_backend = v->gl ? "GL" : "CPU";
    return 0;
}

/* Draws the status text (and the key help when toggled) over the window. */
static void overlay(viewer *v) {
    char buf[2048];
    glrt_timing t;
    glrt_get_timing(v->rt, &t);
    const char *slash = strrchr(v->file, '/');
    int n = snprintf(buf, sizeof buf,
                     "%s   %s runtime%s%s%s   [%.40s, %s]\n"
                     "probe %d/%d: %s   light yaw %.0f pitch %.0f   K %d of %d   exposure %+.1f%s\n"
                     "frame %.1f ms (%.0f fps)   light change %.1f ms %s (+ light vector %.1f ms)   view change %.1f ms %s\n",
                     slash ? slash + 1 : v->file, v->gl ? "GL" : "CPU", v->gl ? " (light kernel " : "",
                     v->gl ? t.light_method_name : "", v->gl ? (v->vertex_model ? ", per-vertex view)" : ", per-pixel view)") : "",
                     t.renderer, t.context,
                     v->probe + 1, v->nprobes, v->names[v->probe], v->lyaw, v->lpitch, v->kmax ? v->kmax : v->kfile,
                     v->kfile, v->exposure,
                     v->d.transfers[0].direct.nvecs == 0 ? "" : v->direct ? "   direct only" : "   direct + bounces", v->frame_ms, v->frame_ms > 0 ? 1e3 / v->frame_ms : 0.0, v->light_ms,
                     v->light_backend ? v->light_backend : "", v->lightvec_ms, v->view_ms,
                     v->view_backend ? v->view_backend : "");
    if (prt_now() < v->status_until && n < (int)sizeof buf) n += snprintf(buf + n, sizeof buf - n, "%s\n", v->status);
    if (n < (int)sizeof buf) snprintf(buf + n, sizeof buf - n, "%s", v->help ? k_keys : "h: help");
    size_t len = strlen(buf);
    while (len && buf[len - 1] == '\n') buf[--len] = 0;
    int scale = v->fbh >= 1400 ? 2 : 1;
    gltext_draw(&v->text, v->fbw, v->fbh, 10, 10, scale, buf);
}

/* Saves the float target as an image file (exposure applied for 8-bit formats). */
static int screenshot(viewer *v, const char *path, prt_error *err) {
    prt_image img;
    if (glrt_read(v->rt, &img, err)) return -1;
    image_desc d = { .exposure = v->exposure };
    int rc = image_write(path, &img, &d, err);
    image_free(&img);
    return rc;
}

/* Saves the window's back buffer as displayed (tone-mapped, text included): 8-bit sRGB codes,
 * decoded to linear so that image_write's sRGB encoding gives the same codes back. */
static int window_screenshot(viewer *v, const char *path, prt_error *err) {
    const gl_api *gl = &v->ctx->gl;
    int w = v->fbw, h = v->fbh;
    uint8_t *px = malloc((size_t)w * h * 4);
    prt_image img;
    if (!px || image_alloc(&img, w, h, 3, err)) { free(px); return prt_fail(err, "out of memory"); }
    gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
    gl->ReadBuffer(GL_BACK);
    gl->PixelStorei(GL_PACK_ALIGNMENT, 1);
    gl->ReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, px);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) {
                float s = px[4 * ((size_t)(h - 1 - y) * w + x) + c] / 255.0f;
                img.data[3 * ((size_t)y * w + x) + c] = s <= 0.04045f ? s / 12.92f : powf((s + 0.055f) / 1.055f, 2.4f);
            }
    free(px);
    image_desc d = { 0 };
    int rc = image_write(path, &img, &d, err);
    image_free(&img);
    return rc;
}

/* One frame: light change if needed, view change if needed, present, text, swap. */
static int frame(viewer *v, bool force_view, prt_error *err) {
    double t0 = prt_now();
    int w, h;
    glfwGetFramebufferSize((GLFWwindow *)v->ctx->window, &w, &h);
    if (w < 1 || h < 1) return 0; /* minimized */
    if (w != v->fbw || h != v->fbh) { v->fbw = w; v->fbh = h; v->view_dirty = true; }
    bool lit = v->light_dirty || v->probe_dirty || (v->gl ? v->g_dirty_gl : v->g_dirty_cpu);
    if (lit && light_change(v, err)) return -1;
    if (lit || v->view_dirty || force_view) {
        if (view_change(v, err)) return -1;
        v->frame_ms = 1e3 * (prt_now() - t0);
    }
    v->view_dirty = false;
    glrt_present(v->rt, v->fbw, v->fbh, v->exposure);
    overlay(v);
    if (v->window_shot_now && window_screenshot(v, v->window_shot, err)) return -1;
    glfwSwapBuffers((GLFWwindow *)v->ctx->window);
    v->present_dirty = false;
    if (prt_now() - v->title_at > 0.5) {
        char title[256];
        snprintf(title, sizeof title, "prt view - %s - %.1f ms/frame", v->file, v->frame_ms);
        glfwSetWindowTitle((GLFWwindow *)v->ctx->window, title);
        v->title_at = prt_now();
    }
    return 0;
}

/* ---------------------------------------------------------------- input */

static void orbit(viewer *v, float dyaw, float dpitch) {
    float off[3];
    v3_sub(off, v->cam.eye, v->cam.target);
    float r = v3_len(off);
    if (r <= 0) return;
    float yaw = atan2f(off[0], off[2]), pitch = asinf(fmaxf(-1.0f, fminf(1.0f, off[1] / r)));
    yaw += dyaw;
    pitch += dpitch;
    const float lim = 89.0f * (float)M_PI / 180.0f;
    if (pitch > lim) pitch = lim;
    if (pitch < -lim) pitch = -lim;
    float d[3] = { cosf(pitch) * sinf(yaw), sinf(pitch), cosf(pitch) * cosf(yaw) };
    v3_madd(v->cam.eye, v->cam.target, d, r);
    v->view_dirty = true;
}

/* Moves eye and target in the view plane by a pixel offset. */
static void pan(viewer *v, float dx, float dy) {
    float f[3], r[3], u[3], off[3];
    camera_basis(&v->cam, f, r, u);
    v3_sub(off, v->cam.eye, v->cam.target);
    float fov = v->cam.fov_deg > 0 ? v->cam.fov_deg : 40;
    float k = 2.0f * v3_len(off) * tanf(fov * (float)M_PI / 360.0f) / (float)(v->fbh > 0 ? v->fbh : 1);
    for (int i = 0; i < 3; i++) {
        float m = (-dx * r[i] + dy * u[i]) * k;
        v->cam.eye[i] += m;
        v->cam.target[i] += m;
    }
    v->view_dirty = true;
}

/* Dollies the eye toward the target by 10% per wheel step, within sane limits. */
static void zoom(viewer *v, float steps) {
    float off[3];
    v3_sub(off, v->cam.eye, v->cam.target);
    float size = 0;
    for (int i = 0; i < 3; i++) size = fmaxf(size, v->d.scene.bmax[i] - v->d.scene.bmin[i]);
    float r = v3_len(off), nr = r * powf(0.9f, steps);
    if (nr < 1e-3f * size) nr = 1e-3f * size;
    if (nr > 100.0f * size + 1) nr = 100.0f * size + 1;
    if (r > 0) v3_madd(v->cam.eye, v->cam.target, off, nr / r);
    v->view_dirty = true;
}

/* Starts a drag: left orbit, shift/ctrl-left light rotation, right/middle pan. */
static void on_mouse_button(GLFWwindow *w, int button, int action, int mods) {
    viewer *v = glfwGetWindowUserPointer(w);
    if (action == GLFW_RELEASE) { v->drag = 0; return; }
    glfwGetCursorPos(w, &v->mx, &v->my);
    if (button == GLFW_MOUSE_BUTTON_LEFT) v->drag = (mods & (GLFW_MOD_SHIFT | GLFW_MOD_CONTROL)) ? 3 : 1;
    else if (button == GLFW_MOUSE_BUTTON_RIGHT || button == GLFW_MOUSE_BUTTON_MIDDLE) v->drag = 2;
}

/* Applies the current drag. */
static void on_cursor(GLFWwindow *w, double x, double y) {
    viewer *v = glfwGetWindowUserPointer(w);
    if (!v->drag) return;
    float dx = (float)(x - v->mx), dy = (float)(y - v->my);
    v->mx = x;
    v->my = y;
    /* Window to framebuffer pixels (HiDPI). */
    int ww, wh;
    glfwGetWindowSize(w, &ww, &wh);
    float sc = ww > 0 ? (float)v->fbw / (float)ww : 1;
    if (v->drag == 1) orbit(v, -dx * 0.008f, dy * 0.008f);
    else if (v->drag == 2) pan(v, dx * sc, dy * sc);
    else {
        v->lyaw += dx * 0.4f;
        v->lpitch += dy * 0.4f;
        v->lyaw = fmodf(v->lyaw + 540.0f, 360.0f) - 180.0f;
        if (v->lpitch > 90) v->lpitch = 90;
        if (v->lpitch < -90) v->lpitch = -90;
        update_rotation(v);
        v->light_dirty = true;
    }
}

/* Wheel: zoom. */
static void on_scroll(GLFWwindow *w, double dx, double dy) {
    viewer *v = glfwGetWindowUserPointer(w);
    zoom(v, (float)dy);
}

/* Switches to probe i (a light change) or says there is no such probe. */
static void select_probe(viewer *v, int i) {
    char msg[160];
    if (i < 0 || i >= v->nprobes) {
        snprintf(msg, sizeof msg, "there %s only %d probe%s", v->nprobes == 1 ? "is" : "are", v->nprobes,
                 v->nprobes == 1 ? "" : "s");
        set_status(v, msg);
        return;
    }
    if (i == v->probe) return;
    v->probe = i;
    v->light_dirty = v->probe_dirty = true;
}

/* S key: saves the float target as PNG (next free prt-view-NNN.png or --screenshot). */
static void take_screenshot(viewer *v) {
    char path[4096], msg[4200];
    if (v->shot_path) snprintf(path, sizeof path, "%s", v->shot_path);
    else {
        do snprintf(path, sizeof path, "prt-view-%03d.png", ++v->shots);
        while (access(path, F_OK) == 0 && v->shots < 999);
    }
    prt_error err = { { 0 } };
    if (screenshot(v, path, &err)) snprintf(msg, sizeof msg, "screenshot failed: %s", err.msg);
    else snprintf(msg, sizeof msg, "saved %s", path);
    set_status(v, msg);
}

/* D key: direct-only lighting vs direct + bounces, when the file keeps both (precompute --keep-direct). */
static void toggle_direct(viewer *v) {
    if (v->d.stats.bounces == 0) {
        set_status(v, "the file has no interreflection passes: it is direct lighting only");
        return;
    }
    if (v->d.transfers[0].direct.nvecs == 0) {
        set_status(v, "the file keeps no direct-only transport (precompute with --keep-direct)");
        return;
    }
    prt_error err = { { 0 } };
    bool want = !v->direct;
    if (!relight_use_direct(v->rc, want) || glrt_use_direct(v->rt, want, &err)) {
        relight_use_direct(v->rc, v->direct);
        char msg[1100];
        snprintf(msg, sizeof msg, "cannot switch the transport: %s", err.msg[0] ? err.msg : "no direct set");
        set_status(v, msg);
        return;
    }
    v->direct = want;
    v->g_dirty_gl = v->g_dirty_cpu = true;
    char msg[128];
    snprintf(msg, sizeof msg, "%s", want ? "direct lighting only" : "direct lighting + interreflections");
    set_status(v, msg);
}

/* Character keys (see k_keys). */
static void on_char(GLFWwindow *w, unsigned int c) {
    viewer *v = glfwGetWindowUserPointer(w);
    switch (c) {
    case '+': case '=': v->exposure += 0.5f; v->present_dirty = true; break;
    case '-': case '_': v->exposure -= 0.5f; v->present_dirty = true; break;
    case 'n': case 'N': select_probe(v, (v->probe + 1) % v->nprobes); break;
    case 'p': case 'P': select_probe(v, (v->probe + v->nprobes - 1) % v->nprobes); break;
    case 'K':
        if (v->kmax == 0 || v->kmax >= v->kfile) set_status(v, "already using every BRDF term the file has");
        else { v->kmax++; if (v->kmax == v->kfile) v->kmax = 0; v->view_dirty = true; }
        break;
    case 'k': {
        int cur = v->kmax ? v->kmax : v->kfile;
        if (cur <= 1) set_status(v, "already at 1 BRDF term");
        else { v->kmax = cur - 1; v->view_dirty = true; }
        break;
    }
    case 'b': case 'B':
        v->gl = !v->gl;
        v->view_dirty = true;
        set_status(v, v->gl ? "GL runtime" : "CPU runtime");
        break;
    case 'v': case 'V':
        v->vertex_model = !v->vertex_model;
        glrt_set_view_mode(v->rt, v->vertex_model ? GLRT_VIEW_VERTEX : GLRT_VIEW_PIXEL);
        v->view_dirty = true;
        set_status(v, v->vertex_model ? "GL view model: per vertex (as the CPU runtime)" : "GL view model: per pixel");
        break;
    case 'd': case 'D': toggle_direct(v); break;
    case 's': case 'S': take_screenshot(v); break;
    case 'r': case 'R':
        v->cam = v->cam0;
        v->lyaw = v->lyaw0;
        v->lpitch = v->lpitch0;
        update_rotation(v);
        v->light_dirty = v->view_dirty = true;
        break;
    case 'h': case 'H': case '?': v->help = !v->help; v->present_dirty = true; break;
    case 'q': case 'Q': v->quit = true; break;
    default:
        if (c >= '1' && c <= '9') select_probe(v, (int)(c - '1'));
    }
}

/* Esc quits, F1 toggles help. */
static void on_key(GLFWwindow *w, int key, int scancode, int action, int mods) {
    viewer *v = glfwGetWindowUserPointer(w);
    if (action == GLFW_PRESS && key == GLFW_KEY_ESCAPE) v->quit = true;
    if (action == GLFW_PRESS && key == GLFW_KEY_F1) { v->help = !v->help; v->present_dirty = true; }
}

/* A resized framebuffer needs a new view change. */
static void on_resize(GLFWwindow *w, int width, int height) {
    viewer *v = glfwGetWindowUserPointer(w);
    v->view_dirty = true;
}

/* ---------------------------------------------------------------- setup */

static int add_probe(viewer *v, const char *path, const char *layout) {
    if (v->nprobes >= VIEW_MAX_PROBES) return cli_error(k_view, "at most %d probes", VIEW_MAX_PROBES);
    if (cli_load_probe(k_view, path, layout, &v->probes[v->nprobes])) return 1;
    const char *slash = strrchr(path, '/');
    snprintf(v->names[v->nprobes], sizeof v->names[0], "%s", slash ? slash + 1 : path);
    v->nprobes++;
    return 0;
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Adds every .exr/.hdr/.pfm in dir, sorted by name; 1 after printing an error. */
static int add_probe_dir(viewer *v, const char *dir, const char *layout) {
    DIR *dp = opendir(dir);
    if (!dp) return cli_error(k_view, "%s: cannot open directory", dir);
    char *names[VIEW_MAX_PROBES];
    int n = 0;
    struct dirent *e;
    while ((e = readdir(dp)) && n < VIEW_MAX_PROBES) {
        char ext[16];
        prt_path_ext(e->d_name, ext);
        if (strcmp(ext, "exr") && strcmp(ext, "hdr") && strcmp(ext, "pfm")) continue;
        names[n] = malloc(strlen(dir) + strlen(e->d_name) + 2);
        if (!names[n]) break;
        sprintf(names[n], "%s/%s", dir, e->d_name);
        n++;
    }
    closedir(dp);
    qsort(names, n, sizeof names[0], cmp_str);
    int rc = n ? 0 : cli_error(k_view, "%s: no .exr, .hdr or .pfm probes in it", dir);
    for (int i = 0; i < n; i++) {
        if (!rc) rc = add_probe(v, names[i], layout);
        free(names[i]);
    }
    return rc;
}

/* Releases everything the viewer holds (not v itself). */
static void viewer_free(viewer *v) {
    if (v->ctx) glctx_make_current(v->ctx, NULL);
    gltext_free(&v->text);
    glrt_destroy(v->rt);
    glctx_destroy(v->ctx);
    relight_destroy(v->rc);
    free(v->rgb);
    free(v->L);
    for (int i = 0; i < v->nprobes; i++) probe_free(&v->probes[i]);
    prt_data_free(&v->d);
}

/* `prt view` (see view_help): 0, 1 on errors, 2 on usage errors. */
int cli_view(int argc, char **argv) {
    viewer *v = calloc(1, sizeof *v);
    if (!v) return cli_error(k_view, "out of memory");
    const char *layout = NULL, *cam_s = NULL, *rot_s = NULL, *val, *dirs[16], *paths[VIEW_MAX_PROBES];
    int ndirs = 0, npaths = 0, w = 1024, h = 768, frames = 0;
    v->gl = true;
    for (int i = 1; i < argc; i++) {
        int r;
        if (cli_is_help(argv[i])) { view_help(); free(v); return 0; }
#define OPT(name, var) if ((r = cli_opt(k_view, argc, argv, &i, name, &var))) { if (r < 0) goto usage; continue; }
        OPT("--layout", layout)
        OPT("--camera", cam_s)
        OPT("--light-rotation", rot_s)
        OPT("--screenshot", v->shot_path)
        OPT("--window-shot", v->window_shot)
        OPT("--keys", v->keys)
        if ((r = cli_opt(k_view, argc, argv, &i, "--probe", &val))) {
            if (r < 0) goto usage;
            if (npaths == VIEW_MAX_PROBES) { cli_error(k_view, "at most %d probes", VIEW_MAX_PROBES); goto usage; }
            paths[npaths++] = val;
            continue;
        }
        if ((r = cli_opt(k_view, argc, argv, &i, "--probes", &val))) {
            if (r < 0) goto usage;
            if (ndirs < 16) dirs[ndirs++] = val;
            continue;
        }
        if ((r = cli_opt(k_view, argc, argv, &i, "--size", &val))) {
            if (r < 0 || !cli_size(k_view, val, &w, &h)) goto usage;
            continue;
        }
        if ((r = cli_opt(k_view, argc, argv, &i, "--exposure", &val))) {
            if (r < 0 || !cli_float(k_view, "--exposure", val, -64, 64, &v->exposure)) goto usage;
            continue;
        }
        if ((r = cli_opt(k_view, argc, argv, &i, "--terms", &val))) {
            if (r < 0 || !cli_int(k_view, "--terms", val, 1, 64, &v->kmax)) goto usage;
            continue;
        }
        if ((r = cli_opt(k_view, argc, argv, &i, "--threads", &val))) {
            if (r < 0 || !cli_int(k_view, "--threads", val, 1, 64, &v->nthreads)) goto usage;
            continue;
        }
        if ((r = cli_opt(k_view, argc, argv, &i, "--frames", &val))) {
            if (r < 0 || !cli_int(k_view, "--frames", val, 1, 1000000, &frames)) goto usage;
            continue;
        }
        if ((r = cli_opt(k_view, argc, argv, &i, "--backend", &val))) {
            if (r < 0) goto usage;
            if (!strcmp(val, "gl")) v->gl = true;
            else if (!strcmp(val, "cpu")) v->gl = false;
            else { cli_error(k_view, "unknown --backend '%s' (gl or cpu)", val); goto usage; }
            continue;
        }
        if ((r = cli_opt(k_view, argc, argv, &i, "--view-model", &val))) {
            if (r < 0) goto usage;
            if (!strcmp(val, "pixel")) v->vertex_model = false;
            else if (!strcmp(val, "vertex")) v->vertex_model = true;
            else { cli_error(k_view, "unknown --view-model '%s' (pixel or vertex)", val); goto usage; }
            continue;
        }
#undef OPT
        if (argv[i][0] == '-' && argv[i][1]) { cli_error(k_view, "unknown option '%s' (see --help)", argv[i]); goto usage; }
        if (v->file) { cli_error(k_view, "more than one input file ('%s' and '%s')", v->file, argv[i]); goto usage; }
        v->file = argv[i];
    }
    if (!v->file) { cli_error(k_view, "no input .prt file (see --help)"); goto usage; }
    if ((v->window_shot || v->keys) && !frames) { cli_error(k_view, "--window-shot and --keys need --frames"); goto usage; }
    if (!npaths && !ndirs) { cli_error(k_view, "no light probe (--probe PROBE or --probes DIR)"); goto usage; }
    if (v->shot_path) {
        char ext[16];
        prt_path_ext(v->shot_path, ext);
        if (strcmp(ext, "png") && strcmp(ext, "exr") && strcmp(ext, "jpg") && strcmp(ext, "tif")) {
            cli_error(k_view, "%s: unsupported screenshot format '.%s' (use .png or .exr)", v->shot_path, ext);
            goto usage;
        }
    }
    if (rot_s) {
        float R[9];
        if (probe_parse_rotation(rot_s, R) != 0 || sscanf(rot_s, "%f", &v->lyaw) != 1) {
            cli_error(k_view, "bad --light-rotation '%s' (expected YAW or YAW,PITCH in degrees)", rot_s);
            goto usage;
        }
        const char *comma = strchr(rot_s, ',');
        if (comma) v->lpitch = strtof(comma + 1, NULL);
    }

    prt_error err = { { 0 } };
    int rc = 1;
    if (prtfile_read(v->file, &v->d, &err)) { cli_error(k_view, "%s", err.msg); goto done; }
    if (cli_camera(k_view, &v->d.scene, (float)w / h, cam_s, &v->cam)) {
        rc = 2;
        goto done;
    }
    v->cam0 = v->cam;
    for (int i = 0; i < npaths; i++)
        if (add_probe(v, paths[i], layout)) goto done;
    for (int i = 0; i < ndirs; i++)
        if (add_probe_dir(v, dirs[i], layout)) goto done;
    for (int m = 0; m < v->d.scene.nmaterials; m++)
        if (v->d.factors[m].K > v->kfile) v->kfile = v->d.factors[m].K;
    if (v->kmax >= v->kfile) v->kmax = 0;
    v->lyaw0 = v->lyaw;
    v->lpitch0 = v->lpitch;
    update_rotation(v);

    v->rgb = malloc(sizeof(float) * 3 * (size_t)(v->d.scene.mesh.nverts > 0 ? v->d.scene.mesh.nverts : 1));
    v->rc = relight_create(&v->d, v->nthreads, &err);
    if (!v->rgb || !v->rc) { cli_error(k_view, "%s", v->rc ? "out of memory" : err.msg); goto done; }
    char title[512];
    snprintf(title, sizeof title, "prt view - %s", v->file);
    glctx_window_desc wd = { .width = w, .height = h, .title = title, .visible = true };
    v->ctx = glctx_create(GLCTX_GLFW, &wd, &err);
    if (!v->ctx) { cli_error(k_view, "%s", err.msg); goto done; }
    glrt_desc rdsc = { .ctx = v->ctx, .view = v->vertex_model ? GLRT_VIEW_VERTEX : GLRT_VIEW_PIXEL };
    v->rt = glrt_create(&v->d, &rdsc, &err);
    if (!v->rt) { cli_error(k_view, "%s", err.msg); goto done; }
    if (gltext_init(&v->text, &v->ctx->gl, &err)) { cli_error(k_view, "%s", err.msg); goto done; }
    GLFWwindow *win = (GLFWwindow *)v->ctx->window;
    glfwSetWindowUserPointer(win, v);
    glfwSwapInterval(0); /* frame times are the renderer's, not the display's refresh */
    if (!frames) {
        glfwSetMouseButtonCallback(win, on_mouse_button);
        glfwSetCursorPosCallback(win, on_cursor);
        glfwSetScrollCallback(win, on_scroll);
        glfwSetCharCallback(win, on_char);
        glfwSetKeyCallback(win, on_key);
        glfwSetFramebufferSizeCallback(win, on_resize);
    }
    glrt_timing tm;
    glrt_get_timing(v->rt, &tm);
    fprintf(stderr, "prt view: %s (%d vertices, %d vectors), GL %s on %s (%s), light kernel %s; press h for help\n",
            v->file, v->d.scene.mesh.nverts, v->d.transfers[0].transport.nvecs, tm.version, tm.renderer, tm.context,
            tm.light_method_name);
    v->light_dirty = v->probe_dirty = v->view_dirty = true;
    if (frames) {
        /* Scripted: the first frame is a light change, the others view changes of the same view. */
        double sum_view = 0;
        size_t nkeys = v->keys ? strlen(v->keys) : 0;
        for (int f = 0; f < frames && !glfwWindowShouldClose(win) && !v->quit; f++) {
            glfwPollEvents();
            if (f > 0 && (size_t)(f - 1) < nkeys) on_char(win, (unsigned char)v->keys[f - 1]);
            v->window_shot_now = v->window_shot && f == frames - 1;
            if (frame(v, true, &err)) { cli_error(k_view, "%s", err.msg); goto done; }
            if (f > 0 || frames == 1) sum_view += v->view_ms;
        }
        if (v->shot_path && screenshot(v, v->shot_path, &err)) { cli_error(k_view, "%s", err.msg); goto done; }
        printf("view: %d frames at %dx%d, %s runtime: light change %.1f ms (light vector %.1f ms), view change %.2f ms "
               "mean%s%s\n",
               frames, v->fbw, v->fbh, v->gl ? "GL" : "CPU", v->light_ms, v->lightvec_ms,
               sum_view / (frames > 1 ? frames - 1 : 1), v->shot_path ? ", saved " : "", v->shot_path ? v->shot_path : "");
    } else {
        while (!glfwWindowShouldClose(win) && !v->quit) {
            bool busy = v->light_dirty || v->view_dirty || v->probe_dirty || v->drag;
            if (busy) glfwPollEvents();
            else glfwWaitEventsTimeout(0.25);
            bool status_visible = v->status[0] && prt_now() < v->status_until + 0.3;
            if (v->light_dirty || v->view_dirty || v->probe_dirty || v->present_dirty || (v->gl ? v->g_dirty_gl : v->g_dirty_cpu) ||
                status_visible)
                if (frame(v, false, &err)) { cli_error(k_view, "%s", err.msg); goto done; }
        }
    }
    rc = 0;
done:
    viewer_free(v);
    free(v);
    return rc;
usage:
    free(v);
    return 2;
}

/* ---------------------------------------------------------------- glbench */

static void glbench_help(void) {
    puts("usage: prt glbench FILE.prt --probe PROBE [--size WxH] [--runs N] [--terms K] [--threads T]\n"
         "\n"
         "Times light changes (sparse T x L for every vector) and view changes (view maps and\n"
         "drawing one frame) with the GLSL runtime and with the CPU runtime, and prints them as\n"
         "frame rates beside the paper's Table II (GeForce 6800 / Pentium 4, Bunny).\n"
         "GL runs headless (OSMesa, or EGL on an NVIDIA machine; PRT_GL=osmesa|egl overrides).\n"
         "\n"
         "  --probe PROBE    light probe\n"
         "  --size WxH       frame size for view changes (default 800x600)\n"
         "  --runs N         timed repetitions of each measurement (default 5; the median is shown)\n"
         "  --terms K        BRDF terms used in view changes (default: all)\n"
         "  --threads T      CPU runtime threads (default: all cores)\n"
         "  --kernel K       GL light kernel: auto (default), fragment, thread, warp");
}

/* qsort order for doubles. */
static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median of x[0..n) (sorts x). */
static double median(double *x, int n) {
    qsort(x, n, sizeof *x, cmp_double);
    return n % 2 ? x[n / 2] : 0.5 * (x[n / 2 - 1] + x[n / 2]);
}

/* `prt glbench` (see glbench_help): 0, 1 on errors, 2 on usage errors. */
int cli_glbench(int argc, char **argv) {
    const char *k_cmd = "glbench", *in = NULL, *probe_path = NULL, *val, *kernel = "auto";
    int w = 800, h = 600, runs = 5, kmax = 0, nthreads = 0;
    for (int i = 1; i < argc; i++) {
        int r;
        if (cli_is_help(argv[i])) { glbench_help(); return 0; }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--probe", &probe_path))) { if (r < 0) return 2; continue; }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--kernel", &kernel))) { if (r < 0) return 2; continue; }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--size", &val))) {
            if (r < 0 || !cli_size(k_cmd, val, &w, &h)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--runs", &val))) {
            if (r < 0 || !cli_int(k_cmd, "--runs", val, 1, 1000, &runs)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--terms", &val))) {
            if (r < 0 || !cli_int(k_cmd, "--terms", val, 1, 64, &kmax)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--threads", &val))) {
            if (r < 0 || !cli_int(k_cmd, "--threads", val, 1, 64, &nthreads)) return 2;
            continue;
        }
        if (argv[i][0] == '-' && argv[i][1]) { cli_error(k_cmd, "unknown option '%s' (see --help)", argv[i]); return 2; }
        if (in) { cli_error(k_cmd, "more than one input file ('%s' and '%s')", in, argv[i]); return 2; }
        in = argv[i];
    }
    if (!in) { cli_error(k_cmd, "no input .prt file (see --help)"); return 2; }
    if (!probe_path) { cli_error(k_cmd, "no light probe (--probe PROBE)"); return 2; }
    glrt_light_method method = GLRT_LIGHT_AUTO;
    if (!strcmp(kernel, "fragment")) method = GLRT_LIGHT_FRAGMENT;
    else if (!strcmp(kernel, "thread")) method = GLRT_LIGHT_THREAD;
    else if (!strcmp(kernel, "warp")) method = GLRT_LIGHT_WARP;
    else if (strcmp(kernel, "auto")) { cli_error(k_cmd, "unknown --kernel '%s' (auto, fragment, thread, warp)", kernel); return 2; }

    prt_error err = { { 0 } };
    prt_data d;
    memset(&d, 0, sizeof d);
    if (prtfile_read(in, &d, &err)) return cli_error(k_cmd, "%s", err.msg);
    prt_probe probe;
    memset(&probe, 0, sizeof probe);
    int rc = 1;
    relight_ctx *rcx = NULL;
    glrt *rt = NULL;
    float *rgb = NULL;
    float(*L)[4] = NULL;
    double *t = calloc((size_t)runs, sizeof(double));
    if (cli_load_probe(k_cmd, probe_path, NULL, &probe)) goto done;
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    if (cube) { probe_to_cube(&probe, CUBE_RES, NULL, 0, cube); L = transfer_light_vector(&d, cube); }
    free(cube);
    rgb = malloc(sizeof(float) * 3 * (size_t)(d.scene.mesh.nverts > 0 ? d.scene.mesh.nverts : 1));
    if (!L || !rgb || !t) { cli_error(k_cmd, "out of memory"); goto done; }
    prt_camera cam;
    cli_camera(k_cmd, &d.scene, (float)w / h, NULL, &cam);   /* no --camera: cannot fail */
    int kfile = 0;
    for (int m = 0; m < d.scene.nmaterials; m++)
        if (d.factors[m].K > kfile) kfile = d.factors[m].K;
    int kuse = kmax > 0 && kmax < kfile ? kmax : kfile;

    glrt_desc desc = { .light = method };
    rt = glrt_create(&d, &desc, &err);
    if (!rt) { cli_error(k_cmd, "%s", err.msg); goto done; }
    if (glrt_set_background(rt, &probe, NULL, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
    rcx = relight_create(&d, nthreads, &err);
    if (!rcx) { cli_error(k_cmd, "%s", err.msg); goto done; }
    glrt_timing tm;
    glrt_get_timing(rt, &tm);
    printf("prt glbench: %s: %d vertices, %d triangles, %d vectors, %zu coefficients (%d-bit), K %d (using %d), "
           "%dx%d frames\n",
           in, d.scene.mesh.nverts, d.scene.mesh.ntris, d.transfers[0].transport.nvecs, (size_t)d.transfers[0].transport.coef_first[d.transfers[0].transport.nvecs],
           d.transfers[0].transport.qbits, kfile, kuse, w, h);
    printf("GL: %s, %s (%s context); light kernel %s", tm.renderer, tm.version, tm.context, tm.light_method_name);
    if (method == GLRT_LIGHT_AUTO) {
        printf(" (measured:");
        for (int k = GLRT_LIGHT_FRAGMENT; k < GLRT_LIGHT_COUNT; k++)
            if (tm.method_ms[k] > 0) printf(" %s %.2f ms", glrt_light_method_name((glrt_light_method)k), tm.method_ms[k]);
        printf(")");
    }
    printf("\nCPU: %d threads\n\n", prt_thread_count(nthreads));

    double res[2][2], gpu[2] = { 0, 0 };
    /* GL light change: upload L + kernel, finished. */
    glrt_set_light(rt, (const float (*)[4])L, &err); /* warm-up */
    double gsum = 0;
    for (int r = 0; r < runs; r++) {
        if (glrt_set_light(rt, (const float (*)[4])L, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
        glrt_get_timing(rt, &tm);
        t[r] = tm.light_ms;
        gsum += tm.light_gpu_ms;
    }
    res[0][0] = median(t, runs);
    gpu[0] = gsum / runs;
    /* GL view change: one frame (per-pixel view maps), finished. */
    glrt_draw(rt, &cam, w, h, kuse, &err);
    gsum = 0;
    for (int r = 0; r < runs; r++) {
        cam.eye[0] += 1e-4f; /* a different view each time */
        if (glrt_draw(rt, &cam, w, h, kuse, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
        glrt_get_timing(rt, &tm);
        t[r] = tm.view_ms;
        gsum += tm.view_gpu_ms;
    }
    res[0][1] = median(t, runs);
    gpu[1] = gsum / runs;
    /* CPU light change: relight_set_light (sparse T x L, all threads). */
    relight_set_light(rcx, (const float (*)[4])L);
    for (int r = 0; r < runs; r++) {
        double t0 = prt_now();
        relight_set_light(rcx, (const float (*)[4])L);
        t[r] = 1e3 * (prt_now() - t0);
    }
    res[1][0] = median(t, runs);
    /* CPU view change: per-vertex view maps (relight_view), then drawing the colours with the same GL
     * raster (finished). */
    double *t2 = calloc((size_t)runs, sizeof(double));
    if (!t2) { cli_error(k_cmd, "out of memory"); goto done; }
    for (int r = 0; r < runs; r++) {
        cam.eye[0] += 1e-4f;
        double t0 = prt_now();
        relight_view(rcx, cam.eye, kuse, rgb);
        t2[r] = 1e3 * (prt_now() - t0);
        if (glrt_draw_vertex_colors(rt, &cam, w, h, rgb, &err)) { free(t2); cli_error(k_cmd, "%s", err.msg); goto done; }
        t[r] = 1e3 * (prt_now() - t0);
    }
    res[1][1] = median(t, runs);
    double t_maps = median(t2, runs);
    free(t2);

    printf("%-30s %24s %24s\n", "", "light change", "view change");
    printf("%-30s %11.2f fps (%7.1f ms) %11.2f fps (%7.1f ms)\n", "GL runtime (wall, finished)", 1e3 / res[0][0],
           res[0][0], 1e3 / res[0][1], res[0][1]);
    printf("%-30s %11.2f fps (%7.1f ms) %11.2f fps (%7.1f ms)\n", "GL runtime (GPU timer query)",
           gpu[0] > 0 ? 1e3 / gpu[0] : 0, gpu[0], gpu[1] > 0 ? 1e3 / gpu[1] : 0, gpu[1]);
    printf("%-30s %11.2f fps (%7.1f ms) %11.2f fps (%7.1f ms) = view maps %.1f ms + raster %.1f ms\n",
           "CPU runtime", 1e3 / res[1][0], res[1][0], 1e3 / res[1][1], res[1][1], t_maps, res[1][1] - t_maps);
    printf("glbench: K=%d gl_light_ms=%.3f gl_view_ms=%.3f cpu_light_ms=%.3f cpu_view_ms=%.3f kernel=%s\n", kuse,
           res[0][0], res[0][1], res[1][0], res[1][1], tm.light_method_name);
    printf("\npaper, Table II (Bunny, 36K + 31K floor vertices, GeForce 6800 / Pentium 4 2.4 GHz):\n"
           "  GPU 1-term: light change 31 fps, view change 226 fps\n"
           "  CPU 1-term: light change 12 fps, view change 79 fps\n"
           "  CPU 4-term: light change 4.8 fps, view change 62 fps (GPU 4-term view change 97 fps)\n");
    rc = 0;
done:
    free(t);
    free(L);
    free(rgb);
    relight_destroy(rcx);
    glrt_destroy(rt);
    probe_free(&probe);
    prt_data_free(&d);
    return rc;
}
