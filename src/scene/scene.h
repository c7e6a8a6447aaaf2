/* scene.h - a scene: models with transforms and materials, plus an optional floor.
 *
 * A scene is what `prt precompute` reads: either one model file (OBJ, glTF 2.0 .gltf/.glb, PLY;
 * asset.h: an OBJ naming an MTL library, a glTF and a PLY are read through assimp, with their
 * materials, textures, lights and cameras; --material and --floor flags) or a small JSON file:
 *
 *     { "models": [ { "obj": "bunny.obj",          (path relative to the JSON file)
 *                     "material": "phong:kd=0.6,0.05,0.05;ks=0.4;n=50",
 *                     "scale": 1.0, "translate": [0,0,0], "rotate_y": 0 },
 *                   { "sphere": {"center":[0,1,0], "radius":1}, "material": "lambert:kd=0.8" } ],
 *       "floor": { "vertices": 31000, "material": "lambert:kd=0.7", "size": 3.0 } }
 *
 * Models may also be procedural (defaults in brackets):
 *     "sphere": {"center":[0,0,0], "radius":1, "rings":32, "segments":64}
 *     "box":    {"min":[-.5,0,-.5], "max":[.5,1,.5], "open_top":false, "n":8}
 *     "torus":  {"center":[0,0,0], "major":1, "minor":0.25, "nu":64, "nv":32}
 *     "plane":  {"x":[-1,1], "z":[-1,1], "height":0, "nx":32, "nz":32}
 * A model has exactly one shape key, plus optional "material" (default
 * desc->material, else "lambert:kd=0.8"), "scale" (> 0), "translate", "rotate_x" and
 * "rotate_y" (degrees, right-handed; p' = scale * Ry * Rx * p + translate) and "name"
 * (ignored). "obj" names any model file (.obj, .gltf, .glb, .ply); its lights and cameras move
 * with the model's transform, and its own materials are used unless "material" (or --material)
 * is given, which replaces them all. Paths of model files are relative to the JSON file (absolute
 * ones are kept).
 * "floor" may also be true/false; a top-level "comment" is ignored.
 * "lights" (lights.h) is an array of local lights, each a spec string
 * ("spot:pos=0,2,0;dir=0,-1,0;inner=20;outer=30;intensity=10") or an object
 * {"type":"point"|"spot", "pos":[x,y,z], "dir":[x,y,z], "inner":DEG, "outer":DEG,
 *  "intensity":W_PER_SR, "colour":[r,g,b]} with light_parse's defaults; at most
 * PRT_MAX_LIGHTS. "light_prior" (prior.h) names the probe, or an array of up to 16 probes,
 * the scene will be lit by (relative to the JSON file): precompute weighs its coefficient selection
 * by their light, as --light-prior does, unless told otherwise. "refine" (refine.h) is
 * true/false or {"threshold": F, "budget": V, "models": true/false}: precompute refines the mesh
 * where visibility changes first, as --refine does, unless its command line has a refine flag
 * (those replace the scene's). Any other key is
 * an error. Example scenes: data/ (data/README.md). The floor is a tessellated plane just below the models
 * (at the lowest y minus 0.1% of the scene size so that a touching model does not
 * z-fight), centred under them, `size` times the models' largest horizontal extent
 * (default 3), with about `vertices` vertices (default 31,000).
 *
 * Materials are BRDF spec strings (see brdf.h: brdf_parse). Identical specs
 * share one material (unless their textures differ). The scene's mesh holds every model merged;
 * mesh.mat[v] indexes scene.materials, material_from[m] says where each came from (the effects
 * plan prints it), material_texture[m] names the texture multiplying its kd (texture.h; the mesh's
 * uv then holds every vertex's coordinates). cameras are a glTF's, notes what loading left out.
 *
 * Ownership: scene_free frees the mesh, materials and textures. */
#ifndef PRT_SCENE_H
#define PRT_SCENE_H
#include "common.h"
#include "mesh.h"
#include "brdf.h"
#include "lights.h"
#include "camera.h"
#include "texture.h"

#define PRT_MAX_MATERIALS 64
#define SCENE_MAX_TEXTURES 32
#define SCENE_MAX_CAMERAS 16
#define SCENE_NOTES_BYTES 4096

/* A camera the scene names (a glTF camera, asset.h): render, view and reference take the first as
 * their default and `--camera-name NAME` picks one. */
typedef struct scene_camera {
    char name[64];      /* the camera's node name, printable ASCII, NUL-terminated */
    prt_camera cam;     /* world space; fov_deg is the vertical field */
} scene_camera;

/* The JSON's "refine" (refine.h): how the scene asks to be refined where visibility
 * changes before its transport; precompute applies it unless its command line says otherwise.
 * Zero fields take refine.h's defaults. */
typedef struct scene_refine {
    bool on;            /* "refine": true, or an object */
    float threshold;    /* "threshold": share of directions, 0 < t < 1 (0: REFINE_THRESHOLD) */
    int budget;         /* "budget": most vertices after refinement (0: 1.5x the scene's) */
    bool models;        /* "models": the models' edges too, not only the floor's */
} scene_refine;

typedef struct prt_scene {
    prt_mesh mesh;
    int nmaterials;
    brdf_params materials[PRT_MAX_MATERIALS];
    char material_spec[PRT_MAX_MATERIALS][256];   /* the spec string each came from */
    char material_from[PRT_MAX_MATERIALS][192];   /* where: "--material", "models[1].material",
                                                   * "box.glb material 'red' (glTF metallic-roughness...)" */
    int floor_first_vertex;    /* first vertex of the floor, or -1 when there is none */
    float bmin[3], bmax[3];    /* bounds of everything, floor included */
    mesh_load_stats load_stats; /* summed over OBJ models */
    prt_lights lights;         /* local lights: the JSON's "lights", plus --light flags */
    char light_prior[8192];    /* the JSON's "light_prior" probes, resolved and comma-joined ("": none) */
    scene_refine refine;       /* the JSON's "refine" (all zero: not asked for) */
    int ncameras;              /* the assets' cameras (asset.h), in file order */
    scene_camera cameras[SCENE_MAX_CAMERAS];
    char notes[SCENE_NOTES_BYTES]; /* what loading left out or changed, one "FILE: what" a line
                                    * (asset.h: a skinned mesh at rest, an ignored extension); "" none */
    int ntextures;             /* base-colour textures (texture.h); the mesh's uv then holds coordinates */
    scene_texture textures[SCENE_MAX_TEXTURES];
    uint8_t material_texture[PRT_MAX_MATERIALS]; /* 0: none; t + 1: textures[t] multiplies the material's
                                                  * diffuse albedo (kd) at each point */
} prt_scene;
#define SCENE_MAX_PRIOR_PROBES 16   /* prior.h's PRIOR_MAX_PROBES */

typedef struct scene_desc {
    const char *material;   /* spec for an OBJ given alone (NULL: "lambert:kd=0.8") */
    int floor;              /* 1: add a floor, 0: none, -1: as the JSON file says (default 0 for OBJ) */
    int floor_verts;        /* 0: as the JSON says, else 31000 */
    const char *floor_material; /* NULL: "lambert:kd=0.7" */
} scene_desc;

/* Loads a model file (.obj, .gltf, .glb, .ply: one model) or a .json scene. desc may be NULL. */
int scene_load(const char *path, const scene_desc *desc, prt_scene *out, prt_error *err);

/* Builds a scene from JSON text held in memory (len bytes); name stands for the file in
 * errors and is the base of relative OBJ paths. desc may be NULL. */
int scene_parse_json(const char *name, const char *text, size_t len, const scene_desc *desc, prt_scene *out,
                     prt_error *err);

/* Builds a scene from a mesh already in memory (takes ownership of *mesh, zeroing it). */
int scene_from_mesh(prt_mesh *mesh, const char *material, prt_scene *out, prt_error *err);

/* Adds a floor under the current contents (see header comment): an n x n grid,
 * n = round(sqrt(verts)) (at least 2); verts <= 0 is an error; size 0 means 3;
 * material NULL means "lambert:kd=0.7". Sets floor_first_vertex; fails if there is
 * already a floor or no geometry. On failure the scene is unchanged. */
int scene_add_floor(prt_scene *s, int verts, float size, const char *material, prt_error *err);

/* Adds (or finds) a material by spec; returns its index or -1 with err set. */
int scene_material(prt_scene *s, const char *spec, prt_error *err);
/* scene_material, recording `from` (where the spec came from; truncated to fit) when the material
 * is new, so the effects plan can say where each material came from. */
int scene_material_from(prt_scene *s, const char *spec, const char *from, prt_error *err);

/* scene_material_from for a material whose diffuse albedo texture tex (index into s->textures, -1:
 * none) multiplies: shared only with a material of the same spec and texture. */
int scene_material_textured(prt_scene *s, const char *spec, const char *from, int tex, prt_error *err);

/* The texture multiplying material m's diffuse albedo, or NULL. */
const scene_texture *scene_material_tex(const prt_scene *s, int m);
/* The albedo multiplier at vertex v: its material's texture at its UV, (1,1,1) without one. */
void scene_vertex_albedo(const prt_scene *s, int v, float rgb[3]);
/* The texture's mean over triangle t (its first vertex's material; (1,1,1) without one): the
 * multiplier of light leaving the triangle in interreflection passes. */
void scene_triangle_albedo(const prt_scene *s, int t, float rgb[3]);

/* Appends one line "text" to s->notes (printf-style; a line that does not fit is dropped, the last
 * kept line then says "..."). */
void scene_note(prt_scene *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* The range of scene coordinates prt computes with (docs/design/scale.md): every position of
 * the mesh (floor included) and of the local lights within +-SCENE_MAX_COORD, and a mesh at
 * least SCENE_MIN_SIZE across (its bounding-box diagonal). Inside it the scale does not matter
 * (the ray tracer, lengths and the camera work in scaled units); outside it float arithmetic
 * overflows or underflows on the way to the image. */
#define SCENE_MAX_COORD 1e30
#define SCENE_MIN_SIZE 1e-30
/* Returns 0 when s is inside that range, else -1 with err set to one line naming what is out of
 * range and what to do ("coordinates up to 3e+35 overflow float arithmetic; ..."); no file name
 * (the caller's). scene_load and scene_parse_json check every scene they make. */
int scene_check_scale(const prt_scene *s, prt_error *err);

/* Recomputes s->bmin/bmax. */
void scene_update_bounds(prt_scene *s);

/* Bounds of what a camera should frame: the models without the floor (everything when
 * there is no floor or nothing but the floor). */
void scene_focus_bounds(const prt_scene *s, float bmin[3], float bmax[3]);

/* The built-in demo scene: a chrome sphere, a glossy sphere, a diffuse box and torus over a
 * floor of about floor_verts (> 0) vertices, with its "refine" and "light_prior" keys (the
 * prior's path is relative to the working directory: the text has no folder). It is JSON
 * (scene_demo_json), the same text as data/demo.json, so that `prt demo` needs no file. */
int scene_make_demo(prt_scene *out, int floor_verts, prt_error *err);

/* The demo scene's JSON text (static; byte for byte data/demo.json). */
const char *scene_demo_json(void);

void scene_free(prt_scene *s);
#endif
