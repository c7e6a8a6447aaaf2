/* asset.h - models in exchange formats: glTF 2.0 (.gltf, .glb), PLY and OBJ with MTL materials,
 * read through the Open Asset Import Library (assimp's C API, assimp/cimport.h).
 *
 * Usage:
 *     asset_model am; prt_error err;
 *     asset_desc ad = { .material = NULL, .fallback = "lambert:kd=0.8" };
 *     if (asset_load("car.glb", &ad, &scene, &am, &err) != 0) { puts(err.msg); ... }
 *     ... am.mesh (world space, mat[] indexes scene.materials), am.lights, am.cameras ...
 *     asset_model_free(&am);
 *
 * What comes out. One mesh: every triangle mesh of the file's node tree, each instance with its
 * node's global transform applied (positions by the matrix, normals by its inverse transpose; a
 * mirroring transform reverses the winding), so a mesh used by two nodes appears twice. The
 * vertices are the file's (no welding across UV seams: a glTF vertex is one position, normal and
 * UV); normals are the file's where it has them (unit, finite), else glTF's flat normals (the
 * glTF 2.0 rule), smooth ones for OBJ (assimp's, merged by position) and prt's angle-weighted ones
 * (mesh_compute_normals) for PLY, whose vertices are shared already. Degenerate
 * triangles (twice the area at most 1e-12 of the squared diagonal, mesh.c's rule) are dropped and
 * counted, unused vertices removed; polygons are fanned into triangles (mesh.c's rule too).
 *
 * Materials, each added to the scene with where it came from (scene_material_from), unless
 * desc->material replaces them all (a JSON "material" or --material: that one wins):
 *   - glTF metallic-roughness onto GGX (brdf.h): kd = baseColor (1 - metallic) (the diffuse
 *     lobe; metals have none), ks = F0 = mix(0.04, baseColor, metallic) (the dielectric and
 *     metallic Fresnel split of the glTF 2.0 specification, Appendix B), alpha = roughness^2
 *     (at least 0.001, brdf.h's range), so the effects plan sends a smooth surface to the vMF
 *     path. A primitive without a material takes glTF's default (white, metallic 1,
 *     roughness 1). KHR_materials_* extensions change the lobe in ways a GGX lobe cannot hold
 *     (clear coat, sheen, transmission, volume, ior, specular, iridescence, anisotropy,
 *     specular-glossiness, unlit, emissive strength): each is noted as ignored, one line each.
 *   - MTL Kd, Ks, Ns onto Phong (phong:kd=Kd;ks=Ks;n=Ns; Lambert when Ks is 0).
 *   - PLY has no materials; faces an OBJ leaves without `usemtl` neither: desc->fallback.
 *
 * Textures: a glTF material's baseColorTexture (in a .glb's buffer, a data URI, or a file beside
 * the model) and an MTL's map_Kd become scene textures (texture.h, decoded by OpenImageIO) that
 * multiply the material's kd, read through the vertices' UVs (the channel the material names);
 * the mesh keeps UVs only when some material has a texture. A --material override has none.
 *
 * Lights (glTF KHR_lights_punctual) become prt's local lights (lights.h) at their node's
 * position and -z axis. Units: glTF gives point and spot intensity in candela (lm/sr); prt's
 * intensity is radiant intensity in W/sr. They are converted at the luminous efficacy of
 * 555 nm light, I [W/sr] = I [cd] / 683 (ASSET_LM_PER_W), the factor the glTF exporters of
 * Blender and others apply the other way (Blender's W / 4pi x 683 = cd), so a light exported
 * from a tool with probe-like radiance units comes back in them. The colour goes into `colour`
 * with its largest channel 1 (intensity carries the rest). Spot cone half-angles (glTF
 * innerConeAngle, outerConeAngle, radians) map to inner_deg and outer_deg. glTF's `range` is
 * ignored (prt's lights fall off as 1/d^2 without a cut-off); directional lights are skipped
 * with a note (a distant light is the probe's job).
 *
 * Cameras (glTF perspective cameras) become scene cameras named after their node: eye at the
 * node, looking along its -z, up its +y, vertical field yfov (assimp hands
 * mHorizontalFOV = yfov * aspectRatio over, which is undone), target on the view axis at the
 * distance of the model's centre. Orthographic cameras are skipped with a note.
 *
 * Refused, with one line naming the file and the problem (exit 1 in the CLI): a file assimp
 * cannot read or that fails its validation (a glTF schema error, a missing .bin, a bad
 * accessor), or that fails prt's own checks made before assimp sees it (asset.c: a .glb's
 * lengths, every glTF buffer, view and accessor within its data, a .gltf that is no JSON object,
 * an OBJ's statements and indices, a PLY header), a missing or unreadable texture, glTF
 * triangles that refer to vertices out of range (assimp drops them; their count is checked
 * against the file's accessors), a non-finite coordinate, normal, texture coordinate
 * or transform, no triangles at all, more than PRT_MAX_LIGHTS lights or SCENE_MAX_CAMERAS
 * cameras. Taken with a note in s->notes: points and lines (skipped: prt samples surfaces), a
 * skinned mesh (at its bind pose, untransformed by its bones) and a morphed one (its base shape),
 * an ignored extension, a skipped light or camera.
 *
 * Ownership: asset_model owns its mesh (asset_model_free); materials and notes go into the
 * caller's scene. No global state of prt's: assimp's error string is read right after the call
 * that set it. */
#ifndef PRT_ASSET_H
#define PRT_ASSET_H
#include "common.h"
#include "scene.h"

#define ASSET_LM_PER_W 683.0   /* luminous efficacy at 555 nm: candela -> W/sr */

typedef struct asset_desc {
    const char *material;      /* replaces every material of the file (NULL: the file's) */
    const char *material_from; /* where that came from, for the plan ("--material") */
    const char *fallback;      /* for faces the file gives no material (NULL: "lambert:kd=0.8") */
    bool no_texture_pixels;    /* textures are named but not decoded (the fuzz harnesses) */
} asset_desc;

typedef struct asset_model {
    prt_mesh mesh;            /* world space; mat[v] indexes the scene's materials */
    prt_lights lights;        /* converted KHR_lights_punctual point and spot lights */
    int ncameras;
    scene_camera cameras[SCENE_MAX_CAMERAS];
    mesh_load_stats stats;    /* faces: triangles read; degenerate and unused dropped */
} asset_model;

/* Does path name a format asset_load reads in place of prt's own parsers (.gltf, .glb, .ply)?
 * An .obj goes to mesh.c unless it names an MTL library (scene.c decides). */
bool asset_handles(const char *path);

/* Reads path into *out, adding its materials (and notes) to s. desc may be NULL. Returns 0, or -1
 * with err naming the file and the problem (*out then empty, s's materials possibly grown). */
int asset_load(const char *path, const asset_desc *desc, prt_scene *s, asset_model *out, prt_error *err);

/* asset_load on bytes in memory (the fuzz harnesses' path): hint is the format's extension
 * ("glb", "gltf", "ply", "obj"); a glTF naming another file (a buffer or image URI that is not a
 * data: URI) is refused, since bytes in memory have no folder to find it in. */
int asset_load_memory(const char *name, const char *hint, const void *buf, size_t len, const asset_desc *desc,
                      prt_scene *s, asset_model *out, prt_error *err);

void asset_model_free(asset_model *m);
#endif
