/* fuzz_objmtl.c - asset_load_memory on arbitrary bytes as OBJ through assimp's reader (the path an
 * OBJ naming an MTL library takes; in memory it has no library beside it, so usemtl names materials
 * assimp makes up): an accepted model keeps the invariants of fuzz_asset.h, a refused one gets one
 * line naming the file.
 *
 * Speed: assimp 5.2's OBJ reader streams its input through an IOStreamBuffer whose constructor
 * allocates a 16 MiB cache (4096 x 4096 bytes) and fills it, for every file however small. Under
 * ASan a block that large is a fresh mmap each time (page faults on the fill, shadow poisoning,
 * munmap on release): about 13 ms an import, over 90% of the harness's time (perf). So this
 * harness replaces the C++ operators new and delete (plain, sized and nothrow; ASan's are weak
 * definitions) with ones that keep one large block when it is released and hand it back for the
 * next request of its size: while kept it is poisoned, so a use after release is still reported
 * (use-after-poison), and its redzones are those of the malloc that made it. Every other block
 * goes to ASan's malloc and free, which still report overflows, use after free, double frees and
 * leaks; what is given up is ASan's report of a block from plain new released by free() or the
 * reverse (new[] and delete[] are ASan's own, so their mismatches with new, delete, malloc and
 * free are still reported). */
#include "fuzz_asset.h"
#include <sanitizer/allocator_interface.h>
#include <sanitizer/asan_interface.h>

/* The large block kept between imports (NULL: none), poisoned while kept, and its size. */
typedef struct { void *p; size_t n; } kept_block;

/* One harness process, one thread: the kept block is the allocator's state, like malloc's own. */
static kept_block kept;

/* Blocks this large are assimp's stream caches; smaller ones churn cheaply. */
enum { KEEP_MIN = 4u << 20 };

void *_Znwm(size_t n);
void *_ZnwmRKSt9nothrow_t(size_t n, const void *nothrow);
void _ZdlPv(void *p);
void _ZdlPvm(void *p, size_t n);
void _ZdlPvRKSt9nothrow_t(void *p, const void *nothrow);

/* operator new(size_t): the kept block when there is one of this size, else ASan's malloc. */
void *_Znwm(size_t n) {
    if (kept.p && kept.n == n) {
        void *p = kept.p;
        kept.p = NULL;
        ASAN_UNPOISON_MEMORY_REGION(p, n);
        return p;
    }
    void *p = malloc(n ? n : 1);
    if (!p) abort();   /* new never returns NULL (ASan reports a failed allocation first) */
    return p;
}

/* operator delete(void *): a block of KEEP_MIN bytes or more is poisoned and kept when none is (the
 * kept one released again is a double free), every other block freed. */
void _ZdlPv(void *p) {
    if (p && p == kept.p) {
        fprintf(stderr, "fuzz_objmtl: a %zu-byte block released twice (double free)\n", kept.n);
        abort();
    }
    size_t n = p ? __sanitizer_get_allocated_size(p) : 0;
    if (n >= KEEP_MIN && !kept.p) {
        ASAN_POISON_MEMORY_REGION(p, n);
        kept = (kept_block){ p, n };
        return;
    }
    free(p);
}

/* operator new(size_t, const std::nothrow_t &): as operator new(size_t) (both pair with delete). */
void *_ZnwmRKSt9nothrow_t(size_t n, const void *nothrow) {
    (void)nothrow;
    return _Znwm(n);
}

/* operator delete(void *, size_t): as operator delete(void *). */
void _ZdlPvm(void *p, size_t n) {
    (void)n;
    _ZdlPv(p);
}

/* operator delete(void *, const std::nothrow_t &): as operator delete(void *). */
void _ZdlPvRKSt9nothrow_t(void *p, const void *nothrow) {
    (void)nothrow;
    _ZdlPv(p);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fuzz_asset(data, size, "fuzz.obj", "obj");
    return 0;
}
