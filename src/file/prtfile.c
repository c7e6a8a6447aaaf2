/* prtfile.c - the .prt file: everything precomputation produces, written once
 * and read by every later command (see prtfile.h).
 *
 * Layout (all little-endian):
 *     "PRTF"  u32 version  u64 payload            header, 16 bytes
 *     payload: sections, each  u32 tag  u64 length  bytes[length]
 *     u32 CRC-32 (zlib) of every byte before it
 * Sections (each exactly once; unknown tags are skipped, so later minor additions
 * stay readable):
 *     META  resolutions, statistics, effects plan
 *     MESH  positions, normals, triangles, per-vertex material, floor, bounds, load stats
 *     MATL  per material: BRDF parameters, spec string, factorization (K, maps, sigma)
 *     one per transfer, under its representation's tag (transfer.h), in the order of
 *     d->transfers: written, read and validated by that representation's ops
 *     LITE  optional: the scene's local lights (lights.h), written only when there are some,
 *           so a scene without lights writes no section and a file without one reads with no
 *           lights; read back and validated (light_validate)
 *     CAMS  optional: the scene's named cameras (a glTF's, asset.h), written only when there are
 *           some: count, then per camera its name (string), eye, target, up and vertical field;
 *           validated (finite, field in (0, 180), eye off the target, printable name)
 *     TXTR  optional: base-colour textures (texture.h), written only when there are some: count,
 *           per texture its name, width, height and 8-bit sRGB texels (the decoded pixels, not a
 *           path: an embedded texture has none, and the file stays whole when the model moves);
 *           then per material its texture (0 none, t + 1), then per vertex its u, v (after MESH;
 *           sizes, indices and finite coordinates checked)
 * Scalars are written field by field (never whole structs), so padding and
 * layout of the C structs do not leak into the format (prtio.h).
 *
 * Writing counts each section's length in a first, silent pass of the same
 * serializer, so the file streams out with no copy of the data in memory; it
 * goes to a temporary name and is renamed at the end (prt_atomic_*).
 *
 * Reading maps the file (or, where mmap refuses, reads it into memory), checks magic,
 * version, the payload length against the file size, the CRC (chunks folded on every
 * core and joined), then parses each section with a bounds-checked
 * cursor and finally validates every index the runtime will follow (triangle
 * indices, materials, then each transfer's own checks: per-vertex vector counts
 * against each material's K, coefficient and run offsets, blocks, ascending
 * indices) and that every float is finite. A CRC only catches accidents; these
 * checks are what make a crafted file fail with one line instead of crashing the
 * renderer. A linear transfer keeps its runs and coefficients in windows of the mapped
 * file (linear.h): the largest arrays are never copied. */
#include "prtfile.h"
#include "check.h"
#include "prtio.h"
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#define TAG_META TRANSFER_TAG('M', 'E', 'T', 'A')
#define TAG_MESH TRANSFER_TAG('M', 'E', 'S', 'H')
#define TAG_MATL TRANSFER_TAG('M', 'A', 'T', 'L')
#define TAG_LITE TRANSFER_TAG('L', 'I', 'T', 'E')
#define TAG_CAMS TRANSFER_TAG('C', 'A', 'M', 'S')
#define TAG_TXTR TRANSFER_TAG('T', 'X', 'T', 'R')
#define HEADER_BYTES 16
#define MAX_RES 4096          /* vis_res, gather_res, BRDF map res: far above anything sane */
#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)

static bool data_ok(const prt_data *d, char *why);
static int read_image(const char *name, const uint8_t *buf, size_t size, const prtio_file *file, prt_data *out, prt_error *err);

/* ---- writing ---------------------------------------------------------------------------- */

/* Section writers: each emits its fields in the order its reader takes them. */
static void sec_meta(prt_writer *w, const prt_data *d) {
    const prt_stats *s = &d->stats;
    prtio_put_i32(w, d->vis_res);
    prtio_put_i32(w, d->gather_res);
    prtio_put_f64(w, s->t_brdf);
    prtio_put_f64(w, s->t_visibility);
    prtio_put_f64(w, s->t_transport);
    for (int i = 0; i < PRT_MAX_BOUNCES; i++) prtio_put_f64(w, s->t_bounce[i]);
    prtio_put_f64(w, s->t_write);
    prtio_put_f64(w, s->t_total);
    prtio_put_u64(w, (uint64_t)s->rays_traced);
    prtio_put_u64(w, (uint64_t)s->rays_hit);
    prtio_put_f64(w, s->hit_fraction);
    prtio_put_i32(w, s->bounces);
    for (int i = 0; i < PRT_MAX_BOUNCES; i++) prtio_put_f64(w, s->bounce_energy[i]);
    prtio_put_f64(w, s->trunc_rel_err);
    prtio_put_u64(w, (uint64_t)s->peak_rss_bytes);
    prtio_put_str(w, d->plan, sizeof d->plan - 1);
}

static void sec_mesh(prt_writer *w, const prt_data *d) {
    const prt_scene *sc = &d->scene;
    const prt_mesh *m = &sc->mesh;
    prtio_put_i32(w, m->nverts);
    prtio_put_i32(w, m->ntris);
    prtio_put_arr(w, m->pos, 3 * (size_t)m->nverts, 4);
    prtio_put_arr(w, m->nrm, 3 * (size_t)m->nverts, 4);
    prtio_put_arr(w, m->tris, 3 * (size_t)m->ntris, 4);
    prtio_put_arr(w, m->mat, (size_t)m->nverts, 2);
    prtio_put_i32(w, sc->floor_first_vertex);
    for (int k = 0; k < 3; k++) prtio_put_f32(w, sc->bmin[k]);
    for (int k = 0; k < 3; k++) prtio_put_f32(w, sc->bmax[k]);
    const mesh_load_stats *ls = &sc->load_stats;
    prtio_put_i32(w, ls->obj_vertices);
    prtio_put_i32(w, ls->faces);
    prtio_put_i32(w, ls->welded);
    prtio_put_i32(w, ls->degenerate);
    prtio_put_i32(w, ls->unused);
}

static size_t factor_len(const brdf_factor *f) { return f->K > 0 ? (size_t)f->res * f->res * f->K * 3 : 0; }

static void sec_matl(prt_writer *w, const prt_data *d) {
    const prt_scene *sc = &d->scene;
    prtio_put_i32(w, sc->nmaterials);
    for (int m = 0; m < sc->nmaterials; m++) {
        const brdf_params *p = &sc->materials[m];
        prtio_put_i32(w, (int32_t)p->type);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, p->kd[k]);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, p->ks[k]);
        prtio_put_f32(w, p->n);
        prtio_put_f32(w, p->nu);
        prtio_put_f32(w, p->nv);
        prtio_put_f32(w, p->alpha);
        prtio_put_i32(w, p->nlobes);
        for (int l = 0; l < BRDF_MAX_LOBES; l++)
            for (int k = 0; k < 4; k++) prtio_put_f32(w, p->lobe[l][k]);
        prtio_put_str(w, sc->material_spec[m], sizeof sc->material_spec[m] - 1);
        const brdf_factor *f = &d->factors[m];
        prtio_put_i32(w, f->K);
        prtio_put_i32(w, f->res);
        prtio_put_i32(w, (int32_t)f->param);
        prtio_put_i32(w, f->nsigma);
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < BRDF_MAX_SIGMA; k++) prtio_put_f32(w, f->sigma[c][k]);
        for (int k = 0; k <= BRDF_MAX_SIGMA; k++) prtio_put_f32(w, f->rel_rms[k]);
        prtio_put_u8(w, f->lambertian ? 1 : 0);
        prtio_put_f64(w, f->seconds);
        prtio_put_arr(w, f->light, factor_len(f), 4);
        prtio_put_arr(w, f->view, factor_len(f), 4);
    }
}

/* LITE: count, then per light type, pos, dir, inner, outer, intensity, colour. */
static void sec_lite(prt_writer *w, const prt_data *d) {
    const prt_lights *ls = &d->scene.lights;
    prtio_put_i32(w, ls->count);
    for (int i = 0; i < ls->count; i++) {
        const prt_light *l = &ls->light[i];
        prtio_put_i32(w, (int32_t)l->type);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, l->pos[k]);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, l->dir[k]);
        prtio_put_f32(w, l->inner_deg);
        prtio_put_f32(w, l->outer_deg);
        prtio_put_f32(w, l->intensity);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, l->colour[k]);
    }
}

/* CAMS: count, then per camera name, eye, target, up, fov_deg. */
static void sec_cams(prt_writer *w, const prt_data *d) {
    const prt_scene *sc = &d->scene;
    prtio_put_i32(w, sc->ncameras);
    for (int i = 0; i < sc->ncameras; i++) {
        const scene_camera *c = &sc->cameras[i];
        prtio_put_str(w, c->name, sizeof c->name - 1);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, c->cam.eye[k]);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, c->cam.target[k]);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, c->cam.up[k]);
        prtio_put_f32(w, c->cam.fov_deg);
    }
}

/* TXTR: textures (name, w, h, sRGB texels), each material's texture, each vertex's u, v. */
static void sec_txtr(prt_writer *w, const prt_data *d) {
    const prt_scene *sc = &d->scene;
    prtio_put_i32(w, sc->ntextures);
    for (int t = 0; t < sc->ntextures; t++) {
        const scene_texture *x = &sc->textures[t];
        prtio_put_str(w, x->name, sizeof x->name - 1);
        prtio_put_i32(w, x->w);
        prtio_put_i32(w, x->h);
        prtio_put_bytes(w, x->srgb, 3 * (size_t)x->w * x->h);
    }
    prtio_put_i32(w, sc->nmaterials);
    prtio_put_bytes(w, sc->material_texture, (size_t)sc->nmaterials);
    prtio_put_i32(w, sc->mesh.nverts);
    prtio_put_arr(w, sc->mesh.uv, 2 * (size_t)sc->mesh.nverts, 4);
}

/* One section: the fixed ones (fn) or transfer tr through its module's writer. */
typedef struct section {
    uint32_t tag;
    void (*fn)(prt_writer *, const prt_data *);
    const prt_transfer *tr;
} section;

static void sec_write(prt_writer *w, const section *s, const prt_data *d) {
    if (s->fn) s->fn(w, d);
    else s->tr->ops->write(w, s->tr);
}

/* The length of section s when its bytes start at offset `at` of the file: a silent pass of its
 * writer from there (a section pads its arrays to offsets from the file's start, prtio_put_pad). */
static uint64_t section_length(const section *s, const prt_data *d, uint64_t at) {
    prt_writer count = { .n = at };
    sec_write(&count, s, d);
    return count.n - at;
}

/* Writes one tagged section: sizes it with a counting pass, then writes it. */
static void put_section(prt_writer *w, const section *s, const prt_data *d) {
    uint64_t len = section_length(s, d, w->n + 12);
    prtio_put_u32(w, s->tag);
    prtio_put_u64(w, len);
    sec_write(w, s, d);
}

/* Writes d to path (temporary file, then rename). Returns 0 or -1 (err names the file). */
int prtfile_write(const char *path, const prt_data *d, prt_error *err) {
    /* Never write what the reader would refuse (an index out of range, a NaN). */
    char why[256];
    if (!data_ok(d, why)) return prt_fail(err, "%s: cannot write: %s", path, why);
    char tmp[4200];
    if (strlen(path) > 4000) return prt_fail(err, "%.60s...: output path too long", path);
    section secs[6 + PRT_MAX_TRANSFERS] = { { TAG_META, sec_meta, NULL }, { TAG_MESH, sec_mesh, NULL },
                                            { TAG_MATL, sec_matl, NULL } };
    int nsec = 3;
    for (int i = 0; i < d->ntransfers; i++) secs[nsec++] = (section){ d->transfers[i].ops->tag, NULL, &d->transfers[i] };
    if (d->scene.lights.count > 0) secs[nsec++] = (section){ TAG_LITE, sec_lite, NULL };
    if (d->scene.ncameras > 0) secs[nsec++] = (section){ TAG_CAMS, sec_cams, NULL };
    if (d->scene.ntextures > 0 && d->scene.mesh.uv) secs[nsec++] = (section){ TAG_TXTR, sec_txtr, NULL };
    FILE *f = prt_atomic_open(path, tmp, sizeof tmp, err);
    if (!f) return -1;
    /* Payload length: the sections, each with its 12-byte tag and length. */
    uint64_t payload = 0;
    for (int i = 0; i < nsec; i++) payload += 12 + section_length(&secs[i], d, HEADER_BYTES + payload + 12);
    prt_writer w = { .f = f, .crc = prtio_crc_init() };
    prtio_put_bytes(&w, "PRTF", 4);
    prtio_put_u32(&w, PRTFILE_VERSION);
    prtio_put_u64(&w, payload);
    for (int i = 0; i < nsec; i++) put_section(&w, &secs[i], d);
    uint32_t crc = (uint32_t)w.crc;
    prtio_put_u32(&w, crc);
    if (w.bad) {
        prt_atomic_abort(f, tmp);
        return prt_fail(err, "%s: write failed: %s", path, strerror(errno));
    }
    return prt_atomic_commit(f, tmp, path, err);
}

/* ---- consistency (shared by the writer and the reader) ------------------------------------ */

/* The transfers: a known count, masks within the materials and covering each of them, and
 * each transfer's own validation (its indices against the mesh and factors). */
static bool transfers_ok(const prt_data *d, char *why) {
    int nm = d->scene.nmaterials;
    if (d->ntransfers < 1 || d->ntransfers > PRT_MAX_TRANSFERS) return BAD(why, "bad transfer count %d", d->ntransfers);
    uint64_t all = nm >= 64 ? ~(uint64_t)0 : ((uint64_t)1 << nm) - 1, covered = 0;
    for (int i = 0; i < d->ntransfers; i++) {
        const prt_transfer *tr = &d->transfers[i];
        if (!tr->ops) return BAD(why, "transfer %d has no representation", i);
        if (tr->materials & ~all) return BAD(why, "%s transfer names materials beyond the %d there are", tr->ops->name, nm);
        covered |= tr->materials;
    }
    for (int m = 0; m < nm; m++)
        if (!((covered >> m) & 1)) return BAD(why, "material %d has no transfer", m);
    for (int i = 0; i < d->ntransfers; i++) {
        const prt_transfer *tr = &d->transfers[i];
        if (!tr->ops->validate(d, tr, why)) return false;
        if (tr->open_sky && (tr->ops->kind != TRANSFER_LINEAR || !tr->open_vert)) return BAD(why, "%s transfer: bad open sky", tr->ops->name);
        for (int v = 0; tr->open_sky && v < d->scene.mesh.nverts; v++) {
            int m = d->scene.mesh.mat ? d->scene.mesh.mat[v] : 0;
            if (tr->open_vert[v] && !(((tr->materials >> m) & 1) && d->factors[m].lambertian))
                return BAD(why, "%s transfer: vertex %d's open sky split, but its material %d is not a Lambertian one it shades",
                           tr->ops->name, v, m);
            const float *n = d->scene.mesh.nrm + 3 * (size_t)v;
            if (tr->open_vert[v] == OPENSKY_FOLDED && (tr->ops->linear->light || n[0] != 0 || n[1] != 1 || n[2] != 0))
                return BAD(why, "%s transfer: vertex %d's open sky split is folded, but %s", tr->ops->name, v,
                           tr->ops->linear->light ? "the representation lights its own model" : "its normal is not (0, 1, 0)");
        }
    }
    return true;
}

/* Every material's BRDF parameters and factorization in range and finite. */
static bool materials_ok(const prt_data *d, char *why) {
    const prt_scene *sc = &d->scene;
    int nm = sc->nmaterials;
    for (int i = 0; i < nm; i++) {
        const brdf_params *p = &sc->materials[i];
        const brdf_factor *f = &d->factors[i];
        if ((int)p->type < 0 || p->type > BRDF_BECKMANN) return BAD(why, "material %d: unknown BRDF type %d", i, (int)p->type);
        if (p->nlobes < 0 || p->nlobes > BRDF_MAX_LOBES) return BAD(why, "material %d: bad lobe count %d", i, p->nlobes);
        float pv[] = { p->kd[0], p->kd[1], p->kd[2], p->ks[0], p->ks[1], p->ks[2], p->n, p->nu, p->nv, p->alpha };
        if (!prtio_all_finite(pv, 10) || !prtio_all_finite(&p->lobe[0][0], 4 * BRDF_MAX_LOBES))
            return BAD(why, "material %d: non-finite BRDF parameters", i);
        if (f->K < 0 || f->K > BRDF_MAX_SIGMA) return BAD(why, "material %d: bad term count K = %d", i, f->K);
        if (f->res < 0 || f->res > MAX_RES || (f->K > 0 && f->res < 1))
            return BAD(why, "material %d: bad BRDF map resolution %d", i, f->res);
        if (f->param != BRDF_PARAM_GRID && f->param != BRDF_PARAM_POLAR)
            return BAD(why, "material %d: bad parameterization %d", i, (int)f->param);
        if (f->nsigma < 0 || f->nsigma > BRDF_MAX_SIGMA) return BAD(why, "material %d: bad singular value count %d", i, f->nsigma);
        if (!isfinite(f->seconds) || !prtio_all_finite(&f->sigma[0][0], 3 * BRDF_MAX_SIGMA) || !prtio_all_finite(f->rel_rms, BRDF_MAX_SIGMA + 1))
            return BAD(why, "material %d: non-finite factor statistics", i);
        if (f->K > 0 && (!f->light || !f->view)) return BAD(why, "material %d: BRDF maps missing", i);
        if (f->K > 0 && (!prtio_all_finite(f->light, factor_len(f)) || !prtio_all_finite(f->view, factor_len(f))))
            return BAD(why, "material %d: non-finite BRDF maps", i);
    }

    return true;
}

/* The textures: a known count, each material's index below it, finite coordinates for every vertex. */
static bool textures_ok(const prt_scene *sc, char *why) {
    if (sc->ntextures < 0 || sc->ntextures > SCENE_MAX_TEXTURES) return BAD(why, "bad texture count %d", sc->ntextures);
    for (int m = 0; m < sc->nmaterials; m++)
        if (sc->material_texture[m] > sc->ntextures) return BAD(why, "material %d uses texture %d of %d", m, sc->material_texture[m] - 1, sc->ntextures);
    for (int t = 0; t < sc->ntextures; t++)
        if (!sc->textures[t].srgb || !sc->textures[t].lin) return BAD(why, "texture %d has no texels", t);
    if (sc->ntextures > 0 && !sc->mesh.uv) return BAD(why, "textures without texture coordinates");
    if (sc->mesh.uv && !prtio_all_finite(sc->mesh.uv, 2 * (size_t)sc->mesh.nverts)) return BAD(why, "non-finite texture coordinates");
    return true;
}

/* The named cameras: a known count, finite, a field in (0, 180), the eye off the target, printable names. */
static bool cameras_ok(const prt_scene *sc, char *why) {
    if (sc->ncameras < 0 || sc->ncameras > SCENE_MAX_CAMERAS) return BAD(why, "bad camera count %d", sc->ncameras);
    for (int i = 0; i < sc->ncameras; i++) {
        const scene_camera *c = &sc->cameras[i];
        const prt_camera *k = &c->cam;
        float v[10] = { k->eye[0], k->eye[1], k->eye[2], k->target[0], k->target[1], k->target[2], k->up[0], k->up[1], k->up[2], k->fov_deg };
        if (!prtio_all_finite(v, 10)) return BAD(why, "camera %d: non-finite values", i);
        if (!(k->fov_deg > 0 && k->fov_deg < 180)) return BAD(why, "camera %d: field of view %g outside (0, 180)", i, (double)k->fov_deg);
        if (k->eye[0] == k->target[0] && k->eye[1] == k->target[1] && k->eye[2] == k->target[2]) return BAD(why, "camera %d: eye on its target", i);
        for (const char *p = c->name; *p; p++)
            if (*p < 32 || *p > 126) return BAD(why, "camera %d: unprintable name", i);
    }
    return true;
}

/* True when everything the runtime will index or print is in range and finite; else
 * false with the first problem in why[256]. Array lengths are those the counts imply
 * (the reader has already matched them against the file). */
static bool data_ok(const prt_data *d, char *why) {
    const prt_stats *s = &d->stats;
    if (d->vis_res < 1 || d->vis_res > MAX_RES || d->gather_res < 1 || d->gather_res > MAX_RES)
        return BAD(why, "bad cube resolutions %d, %d", d->vis_res, d->gather_res);
    if (s->bounces < 0 || s->bounces > PRT_MAX_BOUNCES) return BAD(why, "bad bounce count %d", s->bounces);
    double st[] = { s->t_brdf, s->t_visibility, s->t_transport, s->t_write, s->t_total, s->hit_fraction, s->trunc_rel_err };
    for (size_t i = 0; i < sizeof st / sizeof st[0]; i++)
        if (!isfinite(st[i])) return BAD(why, "non-finite statistics");
    for (int i = 0; i < PRT_MAX_BOUNCES; i++)
        if (!isfinite(s->t_bounce[i]) || !isfinite(s->bounce_energy[i])) return BAD(why, "non-finite statistics");

    const prt_scene *sc = &d->scene;
    const prt_mesh *m = &sc->mesh;
    int nv = m->nverts, nt = m->ntris, nm = sc->nmaterials;
    if (nv < 1 || nt < 1) return BAD(why, "empty mesh (%d vertices, %d triangles)", nv, nt);
    if (!m->pos || !m->nrm || !m->mat || !m->tris) return BAD(why, "mesh arrays missing");
    if (!prtio_all_finite(m->pos, 3 * (size_t)nv) || !prtio_all_finite(m->nrm, 3 * (size_t)nv)) return BAD(why, "non-finite vertex data");
    if (!prtio_all_finite(sc->bmin, 3) || !prtio_all_finite(sc->bmax, 3)) return BAD(why, "non-finite bounds");
    for (size_t i = 0; i < 3 * (size_t)nt; i++)
        if (m->tris[i] >= (uint32_t)nv) return BAD(why, "triangle %zu uses vertex %u of %d", i / 3, m->tris[i], nv);
    if (sc->floor_first_vertex < -1 || sc->floor_first_vertex >= nv) return BAD(why, "bad floor start %d", sc->floor_first_vertex);
    if (nm < 1 || nm > PRT_MAX_MATERIALS) return BAD(why, "bad material count %d", nm);
    for (int v = 0; v < nv; v++)
        if (m->mat[v] >= nm) return BAD(why, "vertex %d uses material %u of %d", v, m->mat[v], nm);
    if (sc->lights.count < 0 || sc->lights.count > PRT_MAX_LIGHTS) return BAD(why, "bad light count %d", sc->lights.count);
    for (int i = 0; i < sc->lights.count; i++) {
        prt_error e;
        if (light_validate(&sc->lights.light[i], "LITE", &e)) return BAD(why, "light %d: %.200s", i, e.msg);
    }
    if (!cameras_ok(sc, why) || !textures_ok(sc, why)) return false;
    prt_error se;   /* precompute refuses such scenes; a file holding one was not written by it */
    if (scene_check_scale(sc, &se)) return BAD(why, "%.200s", se.msg);

    return materials_ok(d, why) && transfers_ok(d, why);
}

/* ---- section readers: sizes and allocation only; data_ok() checks the contents ------------- */

typedef struct parse {
    prt_data *d;
    char why[256];
} parse;

/* Section readers: parse one section into P->d; false with P->why on a short or oversized section. */
static bool rd_meta(parse *P, prt_reader *r) {
    prt_data *d = P->d;
    prt_stats *s = &d->stats;
    d->vis_res = prtio_get_i32(r);
    d->gather_res = prtio_get_i32(r);
    s->t_brdf = prtio_get_f64(r);
    s->t_visibility = prtio_get_f64(r);
    s->t_transport = prtio_get_f64(r);
    for (int i = 0; i < PRT_MAX_BOUNCES; i++) s->t_bounce[i] = prtio_get_f64(r);
    s->t_write = prtio_get_f64(r);
    s->t_total = prtio_get_f64(r);
    s->rays_traced = (long)prtio_get_u64(r);
    s->rays_hit = (long)prtio_get_u64(r);
    s->hit_fraction = prtio_get_f64(r);
    s->bounces = prtio_get_i32(r);
    for (int i = 0; i < PRT_MAX_BOUNCES; i++) s->bounce_energy[i] = prtio_get_f64(r);
    s->trunc_rel_err = prtio_get_f64(r);
    s->peak_rss_bytes = (size_t)prtio_get_u64(r);
    prtio_get_str(r, d->plan, sizeof d->plan);
    return r->bad ? BAD(P->why, "META section too short") : true;
}

static bool rd_mesh(parse *P, prt_reader *r) {
    prt_scene *sc = &P->d->scene;
    prt_mesh *m = &sc->mesh;
    int nv = prtio_get_i32(r), nt = prtio_get_i32(r);
    if (r->bad) return BAD(P->why, "MESH section too short");
    if (nv < 1 || nt < 1 || nv > INT32_MAX / 3 || nt > INT32_MAX / 3)
        return BAD(P->why, "bad mesh size (%d vertices, %d triangles)", nv, nt);
    m->pos = prtio_get_arr(r, 3 * (size_t)nv, 4);
    m->nrm = prtio_get_arr(r, 3 * (size_t)nv, 4);
    m->tris = prtio_get_arr(r, 3 * (size_t)nt, 4);
    m->mat = prtio_get_arr(r, (size_t)nv, 2);
    if (r->bad) return BAD(P->why, "MESH section too short for %d vertices, %d triangles", nv, nt);
    m->nverts = nv;
    m->ntris = nt;
    sc->floor_first_vertex = prtio_get_i32(r);
    for (int k = 0; k < 3; k++) sc->bmin[k] = prtio_get_f32(r);
    for (int k = 0; k < 3; k++) sc->bmax[k] = prtio_get_f32(r);
    mesh_load_stats *ls = &sc->load_stats;
    ls->obj_vertices = prtio_get_i32(r);
    ls->faces = prtio_get_i32(r);
    ls->welded = prtio_get_i32(r);
    ls->degenerate = prtio_get_i32(r);
    ls->unused = prtio_get_i32(r);
    return r->bad ? BAD(P->why, "MESH section too short") : true;
}

static bool rd_matl(parse *P, prt_reader *r) {
    prt_data *d = P->d;
    prt_scene *sc = &d->scene;
    int nm = prtio_get_i32(r);
    if (r->bad) return BAD(P->why, "MATL section too short");
    if (nm < 1 || nm > PRT_MAX_MATERIALS) return BAD(P->why, "bad material count %d", nm);
    sc->nmaterials = nm;
    for (int m = 0; m < nm; m++) {
        brdf_params *p = &sc->materials[m];
        p->type = (brdf_type)prtio_get_i32(r);
        for (int k = 0; k < 3; k++) p->kd[k] = prtio_get_f32(r);
        for (int k = 0; k < 3; k++) p->ks[k] = prtio_get_f32(r);
        p->n = prtio_get_f32(r);
        p->nu = prtio_get_f32(r);
        p->nv = prtio_get_f32(r);
        p->alpha = prtio_get_f32(r);
        p->nlobes = prtio_get_i32(r);
        for (int l = 0; l < BRDF_MAX_LOBES; l++)
            for (int k = 0; k < 4; k++) p->lobe[l][k] = prtio_get_f32(r);
        prtio_get_str(r, sc->material_spec[m], sizeof sc->material_spec[m]);
        brdf_factor *f = &d->factors[m];
        f->K = prtio_get_i32(r);
        f->res = prtio_get_i32(r);
        f->param = (brdf_param)prtio_get_i32(r);
        f->nsigma = prtio_get_i32(r);
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < BRDF_MAX_SIGMA; k++) f->sigma[c][k] = prtio_get_f32(r);
        for (int k = 0; k <= BRDF_MAX_SIGMA; k++) f->rel_rms[k] = prtio_get_f32(r);
        uint8_t lam = prtio_get_u8(r);
        f->lambertian = lam != 0;
        f->seconds = prtio_get_f64(r);
        if (r->bad) return BAD(P->why, "MATL section too short (material %d)", m);
        if (lam > 1) return BAD(P->why, "material %d: bad Lambertian flag", m);
        /* K and res size the maps: check them before allocating. */
        if (f->K < 0 || f->K > BRDF_MAX_SIGMA) return BAD(P->why, "material %d: bad term count K = %d", m, f->K);
        if (f->res < 0 || f->res > MAX_RES || (f->K > 0 && f->res < 1))
            return BAD(P->why, "material %d: bad BRDF map resolution %d", m, f->res);
        if (f->K > 0) {
            f->light = prtio_get_arr(r, factor_len(f), 4);
            f->view = prtio_get_arr(r, factor_len(f), 4);
            if (r->bad) return BAD(P->why, "MATL section too short for material %d's %dx%d maps", m, f->res, f->res);
        }
    }
    return true;
}

/* LITE into d->scene.lights (data_ok validates each light). */
static bool rd_lite(parse *P, prt_reader *r) {
    prt_lights *ls = &P->d->scene.lights;
    int32_t n = prtio_get_i32(r);
    if (r->bad) return BAD(P->why, "LITE section too short");
    if (n < 0 || n > PRT_MAX_LIGHTS) return BAD(P->why, "bad light count %d", n);
    for (int i = 0; i < n; i++) {
        prt_light *l = &ls->light[i];
        int32_t t = prtio_get_i32(r);
        l->type = t == PRT_LIGHT_SPOT ? PRT_LIGHT_SPOT : PRT_LIGHT_POINT;
        if (t != PRT_LIGHT_POINT && t != PRT_LIGHT_SPOT) return BAD(P->why, "light %d has unknown type %d", i, t);
        for (int k = 0; k < 3; k++) l->pos[k] = prtio_get_f32(r);
        for (int k = 0; k < 3; k++) l->dir[k] = prtio_get_f32(r);
        l->inner_deg = prtio_get_f32(r);
        l->outer_deg = prtio_get_f32(r);
        l->intensity = prtio_get_f32(r);
        for (int k = 0; k < 3; k++) l->colour[k] = prtio_get_f32(r);
    }
    if (r->bad) return BAD(P->why, "LITE section too short");
    if (r->pos != r->n) return BAD(P->why, "LITE section longer than its %d lights", n);
    ls->count = n;
    return true;
}

/* CAMS into d->scene.cameras (data_ok validates each). */
static bool rd_cams(parse *P, prt_reader *r) {
    prt_scene *sc = &P->d->scene;
    int32_t n = prtio_get_i32(r);
    if (r->bad) return BAD(P->why, "CAMS section too short");
    if (n < 1 || n > SCENE_MAX_CAMERAS) return BAD(P->why, "bad camera count %d", n);
    for (int i = 0; i < n; i++) {
        scene_camera *c = &sc->cameras[i];
        if (!prtio_get_str(r, c->name, sizeof c->name)) return BAD(P->why, "camera %d: bad name", i);
        for (int k = 0; k < 3; k++) c->cam.eye[k] = prtio_get_f32(r);
        for (int k = 0; k < 3; k++) c->cam.target[k] = prtio_get_f32(r);
        for (int k = 0; k < 3; k++) c->cam.up[k] = prtio_get_f32(r);
        c->cam.fov_deg = prtio_get_f32(r);
    }
    if (r->bad) return BAD(P->why, "CAMS section too short");
    if (r->pos != r->n) return BAD(P->why, "CAMS section longer than its %d cameras", n);
    sc->ncameras = n;
    return true;
}

/* TXTR into d->scene (textures_ok validates the indices and coordinates). */
static bool rd_txtr(parse *P, prt_reader *r) {
    prt_scene *sc = &P->d->scene;
    if (sc->mesh.nverts < 1 || sc->nmaterials < 1) return BAD(P->why, "TXTR before MESH and MATL");
    int32_t n = prtio_get_i32(r);
    if (r->bad || n < 1 || n > SCENE_MAX_TEXTURES) return BAD(P->why, "bad texture count %d", n);
    for (int t = 0; t < n; t++) {
        char name[128];
        bool ok = prtio_get_str(r, name, sizeof name);
        int32_t w = prtio_get_i32(r), h = prtio_get_i32(r);
        if (!ok || r->bad || w < 1 || h < 1 || w > TEXTURE_MAX_SIDE || h > TEXTURE_MAX_SIDE)
            return BAD(P->why, "texture %d: bad name or size %dx%d", t, w, h);
        const uint8_t *px = prtio_peek_arr(r, 3 * (size_t)w * h, 1);
        prt_error e;
        if (!px) return BAD(P->why, "TXTR section too short for texture %d's %dx%d texels", t, w, h);
        if (texture_from_srgb(&sc->textures[t], name, w, h, px, &e)) {
            r->oom = true;
            return BAD(P->why, "%.200s", e.msg);
        }
        sc->ntextures = t + 1;
    }
    int32_t nm = prtio_get_i32(r);
    const uint8_t *mt = nm == sc->nmaterials ? prtio_peek_arr(r, (size_t)nm, 1) : NULL;
    if (!mt) return BAD(P->why, "TXTR: %d material textures for %d materials", nm, sc->nmaterials);
    memcpy(sc->material_texture, mt, (size_t)nm);
    int32_t nv = prtio_get_i32(r);
    if (nv != sc->mesh.nverts) return BAD(P->why, "TXTR: coordinates for %d vertices of %d", nv, sc->mesh.nverts);
    sc->mesh.uv = prtio_get_arr(r, 2 * (size_t)nv, 4);
    if (r->bad) return BAD(P->why, "TXTR section too short");
    if (r->pos != r->n) return BAD(P->why, "TXTR section longer than its contents");
    return true;
}

/* Reads a transfer section of representation ops into a new prt_transfer of P->d. */
static bool rd_transfer(parse *P, prt_reader *r, const transfer_ops *ops) {
    prt_data *d = P->d;
    for (int i = 0; i < d->ntransfers; i++)
        if (d->transfers[i].ops == ops) return BAD(P->why, "two %s sections", ops->name);
    if (d->ntransfers >= PRT_MAX_TRANSFERS) return BAD(P->why, "more than %d transfer sections", PRT_MAX_TRANSFERS);
    prt_transfer *tr = prt_data_add_transfer(d, ops, NULL, 0);
    return ops->read(r, tr, P->why);
}

/* The read path (a file mmap refused): the n bytes of fd read into memory, then read_image. */
static int read_copied(const char *path, int fd, size_t n, prt_data *out, prt_error *err) {
    uint8_t *b = malloc(n);
    if (!b) return prt_fail(err, "%s: out of memory reading %zu bytes", path, n);
    size_t got = 0;
    while (got < n) {
        ssize_t k = pread(fd, b + got, n - got, (off_t)got);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) break;
        got += (size_t)k;
    }
    int rc = got == n ? read_image(path, b, n, NULL, out, err) : prt_fail(err, "%s: read error: %s", path, got < n && errno ? strerror(errno) : "short read");
    free(b);
    return rc;
}

/* The checks of the frame of b[n]: magic, version, payload length, CRC (on every core; with drop, b
 * is a file mapping whose pages leave this process as they are folded). Returns 0 or -1 with one
 * line naming the file. */
static int frame_checked(const char *path, const uint8_t *b, size_t n, bool drop, prt_error *err) {
    if (n == 0) return prt_fail(err, "%s: empty file (not a prt file)", path);
    if (n < 4 || memcmp(b, "PRTF", 4) != 0) return prt_fail(err, "%s: not a prt file (bad magic)", path);
    if (n < HEADER_BYTES + 4) return prt_fail(err, "%s: truncated (%zu bytes, less than a header)", path, n);
    prt_reader h = { .p = b, .n = n, .pos = 4 };
    uint32_t version = prtio_get_u32(&h);
    uint64_t payload = prtio_get_u64(&h);
    if (version >= 1 && version < PRTFILE_VERSION_OLDEST)
        return prt_fail(err, "%s: written by an older prt (file version %u); precompute it again", path, version);
    if (version > PRTFILE_VERSION)
        return prt_fail(err, "%s: version %u not supported (expected %d to %d)", path, version, PRTFILE_VERSION_OLDEST, PRTFILE_VERSION);
    if (payload > n - HEADER_BYTES - 4)
        return prt_fail(err, "%s: truncated (%zu bytes, expected %llu)", path, n, (unsigned long long)(payload + HEADER_BYTES + 4));
    if (payload < n - HEADER_BYTES - 4)
        return prt_fail(err, "%s: corrupt (%zu bytes, but the header says %llu)", path, n, (unsigned long long)(payload + HEADER_BYTES + 4));
    prt_reader tail = { .p = b, .n = n, .pos = n - 4 };
    if ((uint32_t)prtio_crc_threads(b, n - 4, 0, drop) != prtio_get_u32(&tail))
        return prt_fail(err, "%s: corrupt (checksum mismatch)", path);
    return 0;
}

/* Parses one section (tag, bytes) into P; a fixed section twice is refused, an unknown tag skipped.
 * Returns 0, or -1 with one line naming the file. */
static int parse_section(parse *P, const char *path, uint32_t tag, prt_reader *sec, bool seen[3], prt_error *err) {
    static const uint32_t fixed[3] = { TAG_META, TAG_MESH, TAG_MATL };
    static const char *names[3] = { "META", "MESH", "MATL" };
    static bool (*const readers[3])(parse *, prt_reader *) = { rd_meta, rd_mesh, rd_matl };
    bool ok = true;
    const transfer_ops *ops = transfer_by_tag(tag);
    if (ops) {
        ok = rd_transfer(P, sec, ops);
    } else if (tag == TAG_LITE) {
        if (P->d->scene.lights.count > 0) return prt_fail(err, "%s: corrupt (two LITE sections)", path);
        ok = rd_lite(P, sec);
    } else if (tag == TAG_CAMS) {
        if (P->d->scene.ncameras > 0) return prt_fail(err, "%s: corrupt (two CAMS sections)", path);
        ok = rd_cams(P, sec);
    } else if (tag == TAG_TXTR) {
        if (P->d->scene.ntextures > 0) return prt_fail(err, "%s: corrupt (two TXTR sections)", path);
        ok = rd_txtr(P, sec);
    } else {
        int which = -1;
        for (int i = 0; i < 3; i++)
            if (tag == fixed[i]) which = i;
        if (which < 0) return 0;   /* unknown section: skip */
        if (seen[which]) return prt_fail(err, "%s: corrupt (two %s sections)", path, names[which]);
        ok = readers[which](P, sec);
        seen[which] = true;
    }
    if (sec->oom) return prt_fail(err, "%s: out of memory", path);
    if (!ok) return prt_fail(err, "%s: corrupt (%s)", path, P->why);
    return 0;
}

/* Reads the file image buf[size] into out; with file, buf is its mapping and the transfers may keep
 * windows of it. Returns 0, or -1 with one line naming the file (out is then empty). */
static int read_image(const char *name, const uint8_t *buf, size_t size, const prtio_file *file, prt_data *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    out->scene.floor_first_vertex = -1;
    parse P = { .d = out };
    if (frame_checked(name, buf, size, file != NULL, err)) return -1;
    /* Sections; the cross-section checks follow in data_ok(). */
    prt_reader s = { .p = buf, .n = size - 4, .pos = HEADER_BYTES };
    bool seen[3] = { false, false, false };
    int rc = -1;
    while (s.pos < s.n) {
        uint32_t tag = prtio_get_u32(&s);
        uint64_t len = prtio_get_u64(&s);
        if (s.bad || len > s.n - s.pos) {
            prt_fail(err, "%s: corrupt (section runs past the end)", name);
            goto done;
        }
        prt_reader sec = { .p = buf + s.pos, .n = (size_t)len, .file = file };
        s.pos += (size_t)len;
        if (parse_section(&P, name, tag, &sec, seen, err)) goto done;
    }
    static const char *names[3] = { "META", "MESH", "MATL" };
    for (int i = 0; i < 3; i++)
        if (!seen[i]) {
            prt_fail(err, "%s: corrupt (no %s section)", name, names[i]);
            goto done;
        }
    if (out->ntransfers == 0) {
        prt_fail(err, "%s: corrupt (no transfer section)", name);
        goto done;
    }
    if (!data_ok(out, P.why)) {
        prt_fail(err, "%s: corrupt (%s)", name, P.why);
        goto done;
    }
    rc = 0;
done:
    if (rc) prt_data_free(out);
    return rc;
}

/* Reads the bytes buf[size] (copying every array) into out. */
int prtfile_read_memory(const char *name, const uint8_t *buf, size_t size, prt_data *out, prt_error *err) {
    return read_image(name, buf, size, NULL, out, err);
}

/* Maps the file and reads it in place (read_image with the file: the transport sets keep windows
 * of it, paged in by the validation as the runtime will need them, so a light change meets no page
 * fault); when mmap refuses, reads it into memory instead. The windows are private read-only mappings: prt replaces files by
 * renaming (prt_atomic_commit), which leaves a mapped file's pages as they were. */
int prtfile_read(const char *path, prt_data *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    out->scene.floor_first_vertex = -1;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return prt_fail(err, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return prt_fail(err, "%s: not a regular file", path);
    }
    size_t n = (size_t)st.st_size;
    if (n == 0) {
        close(fd);
        return prt_fail(err, "%s: empty file (not a prt file)", path);
    }
    void *m = mmap(NULL, n, PROT_READ, MAP_PRIVATE, fd, 0);
    int rc;
    if (m == MAP_FAILED) {
        rc = read_copied(path, fd, n, out, err);
    } else {
        prtio_file file = { fd, m, n };
        rc = read_image(path, m, n, &file, out, err);
        munmap(m, n);
    }
    close(fd);
    return rc;
}

/* Frees everything in d (scene, factors, transfers) and zeroes it. */
void prt_data_free(prt_data *d) {
    if (!d) return;
    scene_free(&d->scene);
    for (int m = 0; m < PRT_MAX_MATERIALS; m++) brdf_factor_free(&d->factors[m]);
    for (int i = 0; i < d->ntransfers && i < PRT_MAX_TRANSFERS; i++)
        if (d->transfers[i].ops) {
            d->transfers[i].ops->release(&d->transfers[i]);
            free(d->transfers[i].open_vert);   /* a release that did not free it (linear_release does) */
        }
    memset(d, 0, sizeof *d);
    d->scene.floor_first_vertex = -1;
}

/* The transport sets' windows (see prtfile.h). */
size_t prt_data_mapped_bytes(const prt_data *d) {
    size_t n = 0;
    for (int i = 0; i < d->ntransfers && i < PRT_MAX_TRANSFERS; i++) n += d->transfers[i].transport.data_mapped + d->transfers[i].direct.data_mapped;
    return n;
}

/* The first linear transfer, or NULL (see prtfile.h). */
const prt_transfer *prt_data_transfer(const prt_data *d) {
    for (int i = 0; i < d->ntransfers; i++)
        if (d->transfers[i].ops && d->transfers[i].ops->kind == TRANSFER_LINEAR) return &d->transfers[i];
    return NULL;
}

prt_transfer *prt_data_add_transfer(prt_data *d, const transfer_ops *ops, const transfer_config *cfg, uint64_t materials) {
    PRT_CHECK(ops != NULL);
    PRT_CHECK_LT(d->ntransfers, PRT_MAX_TRANSFERS);
    prt_transfer *tr = &d->transfers[d->ntransfers++];
    memset(tr, 0, sizeof *tr);
    tr->ops = ops;
    if (cfg) tr->cfg = *cfg;   /* NULL: zero bytes, filled by ops->read */
    tr->materials = materials;
    return tr;
}
