/* asset_measure.c - load times of prt's OBJ parser against assimp's readers (docs/design/assets.md).
 *
 * tools/asset_measure.sh MODEL.obj [LEVELS] [OUTDIR]: reads MODEL.obj, splits every triangle into
 * four at its edge midpoints LEVELS times (default 2: the 69,451-triangle bunny becomes 1,111,216
 * triangles), writes the result as OUTDIR/sub.obj (v and f lines, %.9g), OUTDIR/sub.glb (glTF 2.0
 * binary: positions, smooth normals as an exporter writes them, uint32 indices) and OUTDIR/sub.ply
 * (binary little-endian), then times, best of 3 each, the loads a user's command does: mesh.c's
 * mesh_load_obj and asset.h's asset_load (assimp) on MODEL.obj and sub.obj, asset_load on sub.glb
 * and sub.ply. Wall seconds, one thread (assimp's readers are serial), page cache warm. */
#include "asset.h"
#include "mesh.h"
#include "scene.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Splits each triangle of m into four at its edge midpoints (shared by both triangles of an edge:
 * an open-addressing table of the edge's vertex pair). */
static void subdivide(prt_mesh *m) {
    size_t nt = (size_t)m->ntris, cap = 1;
    while (cap < 4 * nt) cap <<= 1;
    uint64_t *key = malloc(cap * sizeof *key);
    uint32_t *val = malloc(cap * sizeof *val);
    for (size_t i = 0; i < cap; i++) key[i] = UINT64_MAX;
    size_t nv = (size_t)m->nverts;
    float *pos = malloc(3 * (nv + 3 * nt) * sizeof *pos);
    memcpy(pos, m->pos, 3 * nv * sizeof *pos);
    uint32_t *tris = malloc(12 * nt * sizeof *tris);
    for (size_t t = 0; t < nt; t++) {
        uint32_t c[3], *x = m->tris + 3 * t;
        for (int e = 0; e < 3; e++) {
            uint32_t a = x[e], b = x[(e + 1) % 3], lo = a < b ? a : b, hi = a < b ? b : a;
            uint64_t k = (uint64_t)lo << 32 | hi;
            size_t h = (size_t)((k * 0x9E3779B97F4A7C15ull) >> 20) & (cap - 1);
            while (key[h] != UINT64_MAX && key[h] != k) h = (h + 1) & (cap - 1);
            if (key[h] != k) {
                key[h] = k;
                val[h] = (uint32_t)nv;
                for (int q = 0; q < 3; q++) pos[3 * nv + q] = 0.5f * (m->pos[3 * (size_t)a + q] + m->pos[3 * (size_t)b + q]);
                nv++;
            }
            c[e] = val[h];
        }
        const uint32_t f[12] = { x[0], c[0], c[2], c[0], x[1], c[1], c[2], c[1], x[2], c[0], c[1], c[2] };
        memcpy(tris + 12 * t, f, sizeof f);
    }
    free(key), free(val);
    mesh_free(m);
    m->pos = pos, m->tris = tris, m->nverts = (int)nv, m->ntris = (int)(4 * nt);
    m->mat = calloc(nv, sizeof *m->mat);
    mesh_compute_normals(m);
}

static void write_obj(const prt_mesh *m, const char *path) {
    FILE *f = fopen(path, "w");
    for (int v = 0; v < m->nverts; v++) fprintf(f, "v %.9g %.9g %.9g\n", m->pos[3 * v], m->pos[3 * v + 1], m->pos[3 * v + 2]);
    for (int t = 0; t < m->ntris; t++) fprintf(f, "f %u %u %u\n", m->tris[3 * t] + 1, m->tris[3 * t + 1] + 1, m->tris[3 * t + 2] + 1);
    fclose(f);
}

static void put_u32(FILE *f, uint32_t x) { fwrite(&x, 4, 1, f); }

static void write_glb(const prt_mesh *m, const char *path) {
    size_t nv = (size_t)m->nverts, nt = (size_t)m->ntris, pb = 12 * nv, ib = 12 * nt;
    float lo[3], hi[3];
    mesh_bounds(m, lo, hi);
    char json[2048];
    int n = snprintf(json, sizeof json,
        "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},\"indices\":2}]}],"
        "\"buffers\":[{\"byteLength\":%zu}],\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":%zu},"
        "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\",\"min\":[%.9g,%.9g,%.9g],"
        "\"max\":[%.9g,%.9g,%.9g]},{\"bufferView\":1,\"componentType\":5126,\"count\":%zu,\"type\":\"VEC3\"},"
        "{\"bufferView\":2,\"componentType\":5125,\"count\":%zu,\"type\":\"SCALAR\"}]}",
        2 * pb + ib, pb, pb, pb, 2 * pb, ib, nv, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2], nv, 3 * nt);
    while (n % 4) json[n++] = ' ';
    FILE *f = fopen(path, "wb");
    fwrite("glTF", 1, 4, f);
    put_u32(f, 2);
    put_u32(f, (uint32_t)(12 + 8 + n + 8 + 2 * pb + ib));
    put_u32(f, (uint32_t)n);
    fwrite("JSON", 1, 4, f);
    fwrite(json, 1, (size_t)n, f);
    put_u32(f, (uint32_t)(2 * pb + ib));
    fwrite("BIN\0", 1, 4, f);
    fwrite(m->pos, 4, 3 * nv, f);
    fwrite(m->nrm, 4, 3 * nv, f);
    fwrite(m->tris, 4, 3 * nt, f);
    fclose(f);
}

static void write_ply(const prt_mesh *m, const char *path) {
    FILE *f = fopen(path, "wb");
    fprintf(f, "ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
               "property float z\nelement face %d\nproperty list uchar uint vertex_indices\nend_header\n", m->nverts, m->ntris);
    fwrite(m->pos, 4, 3 * (size_t)m->nverts, f);
    for (int t = 0; t < m->ntris; t++) {
        fputc(3, f);
        fwrite(m->tris + 3 * t, 4, 3, f);
    }
    fclose(f);
}

/* Best of 3 wall seconds of loading path by prt's parser (own) or assimp; its triangle count in *nt. */
static double time_load(const char *path, bool own, int *nt) {
    double best = 1e30;
    for (int r = 0; r < 3; r++) {
        prt_scene s;
        memset(&s, 0, sizeof s);
        prt_error err;
        asset_model am;
        memset(&am, 0, sizeof am);
        double t0 = prt_now();
        int rc = own ? mesh_load_obj(path, NULL, &am.mesh, &err) : asset_load(path, NULL, &s, &am, &err);
        double t = prt_now() - t0;
        if (rc) {
            fprintf(stderr, "%s\n", err.msg);
            exit(1);
        }
        *nt = am.mesh.ntris;
        asset_model_free(&am);
        if (t < best) best = t;
    }
    return best;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: asset_measure MODEL.obj [LEVELS] [OUTDIR]\n");
        return 2;
    }
    int levels = argc > 2 ? atoi(argv[2]) : 2;
    const char *dir = argc > 3 ? argv[3] : "/tmp";
    prt_mesh m;
    prt_error err;
    if (mesh_load_obj(argv[1], NULL, &m, &err)) {
        fprintf(stderr, "%s\n", err.msg);
        return 1;
    }
    for (int l = 0; l < levels; l++) subdivide(&m);
    char obj[4096], glb[4096], ply[4096];
    snprintf(obj, sizeof obj, "%s/sub.obj", dir);
    snprintf(glb, sizeof glb, "%s/sub.glb", dir);
    snprintf(ply, sizeof ply, "%s/sub.ply", dir);
    write_obj(&m, obj);
    write_glb(&m, glb);
    write_ply(&m, ply);
    printf("subdivided %d times: %d vertices, %d triangles\n", levels, m.nverts, m.ntris);
    mesh_free(&m);
    const struct { const char *path; bool own; const char *what; } runs[] = {
        { argv[1], true, "model OBJ, prt's parser" }, { argv[1], false, "model OBJ, assimp" },
        { obj, true, "sub.obj, prt's parser" }, { obj, false, "sub.obj, assimp" },
        { glb, false, "sub.glb, assimp" }, { ply, false, "sub.ply, assimp" },
    };
    double own_big = 0;
    for (size_t i = 0; i < sizeof runs / sizeof runs[0]; i++) {
        int nt = 0;
        double t = time_load(runs[i].path, runs[i].own, &nt);
        if (i == 2) own_big = t;
        printf("%-28s %9d triangles  %8.3f s%s", runs[i].what, nt, t, i >= 3 ? "" : "\n");
        if (i >= 3) printf("  (%.2fx prt's parser on sub.obj)\n", t / own_big);
    }
    return 0;
}
