/*
 * Strands dropped on a head with shoulders through the superhelix C API: a game loop
 * with colliders.
 *
 * Six straight strands of N = 5 elements, 25 cm, are rooted on a head sphere (radius
 * 10 cm, on the head) and start horizontal; under gravity they fall and drape over the
 * sphere onto two shoulder capsules (each on a pose of its own) and onto a box behind
 * the head given as a grid of signed distances the program fills itself (in the world).
 * Sixty steps of 1/60 s; after each, the strands' deepest points and contact counts are
 * read back.
 *
 *   colliders [GRID.npy]      shoulders still; writes the grid's values to GRID.npy
 *                             (float64, shape (nz, ny, nx)) when given
 *   colliders shrug           the shoulders rise by 2 cm over the second half second and
 *                             come back, their poses set before every step
 *   colliders tolerance TOL   error-controlled steps with the contacts (each strand's
 *                             local error below TOL of its length)
 *   colliders samples K       K contact points per element (4 by default); options
 *                             combine
 *
 * It prints, one value per line:
 *
 *   grid <nx> <ny> <nz> <ox> <oy> <oz> <spacing>   the grid's layout
 *   root <s> <x> <y> <z>                         strand s's root (head coordinates)
 *   direction <s> <x> <y> <z>                    its tangent at the root (n0)
 *   deepest <frame> <metres>                     deepest point of any strand after step
 *                                                frame (frame 1 is after the first step)
 *   touching <frame> <count>                     contact points touching, all strands
 *   point <frame> <s> <i> <x> <y> <z>            element end i of strand s (world)
 *
 * Build (from the workspace root, after cargo build -p superhelix-capi --release):
 *
 *   cc -std=c99 -Icapi/include capi/examples/colliders.c \
 *      target/release/libsuperhelix_capi.a -lpthread -ldl -lm -o colliders
 */
#include "superhelix.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define N 5
#define STRANDS 6
#define FRAMES 60
#define DT (1.0 / 60.0)
#define HEAD_RADIUS 0.1

/* The box behind the head: centre and half-sizes, m (world coordinates). */
static const double BOX_CENTER[3] = {0.0, -0.15, -0.19};
static const double BOX_HALF[3] = {0.12, 0.06, 0.04};
/* Its grid: 4 mm cells over the box grown by 3 cells on every side. */
#define CELL 0.004
#define NX 67
#define NY 37
#define NZ 27

/* Prints what failed and returns from main with 1. */
#define CHECK(call)                                                                        \
    do {                                                                                   \
        ShStatus status_ = (call);                                                         \
        if (status_ != SH_STATUS_OK) {                                                     \
            fprintf(stderr, "%s: %s\n", #call, sh_status_message(status_));                \
            if (batch != NULL) {                                                           \
                ShError error_;                                                            \
                if (sh_batch_last_error(batch, &error_) == SH_STATUS_OK &&                 \
                    error_.message[0] != '\0') {                                           \
                    fprintf(stderr, "  %s\n", error_.message);                             \
                }                                                                          \
            }                                                                              \
            sh_batch_free(batch);                                                          \
            free(grid);                                                                    \
            return 1;                                                                      \
        }                                                                                  \
    } while (0)

/* The exact signed distance of the box at p. */
static double box_distance(const double p[3]) {
    double outside = 0.0, inside = -INFINITY;
    for (int a = 0; a < 3; a++) {
        double q = fabs(p[a] - BOX_CENTER[a]) - BOX_HALF[a];
        if (q > 0.0) outside += q * q;
        if (q > inside) inside = q;
    }
    return outside > 0.0 ? sqrt(outside) : inside;
}

/* Writes the grid as a little-endian float64 .npy file of shape (nz, ny, nx). */
static int write_npy(const char *path, const double *values) {
    FILE *f = fopen(path, "wb");
    if (f == NULL) return 0;
    char header[128];
    int len = snprintf(header, sizeof header,
                       "{'descr': '<f8', 'fortran_order': False, 'shape': (%d, %d, %d), }",
                       NZ, NY, NX);
    int total = 10 + len + 1;          /* preamble, dict, '\n' */
    int padded = (total + 63) / 64 * 64; /* the data starts at a multiple of 64 bytes */
    while (len < padded - 11) header[len++] = ' ';
    header[len++] = '\n';
    unsigned char preamble[10] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0,
                                  (unsigned char)(len & 0xff), (unsigned char)(len >> 8)};
    int ok = fwrite(preamble, 1, 10, f) == 10 && fwrite(header, 1, len, f) == (size_t)len &&
             fwrite(values, sizeof(double), (size_t)NX * NY * NZ, f) == (size_t)NX * NY * NZ;
    return fclose(f) == 0 && ok;
}

/* A pose at height dz above the rest (no turn). */
static ShPose lifted(double dz) {
    ShPose p = {{0.0, 0.0, dz}, {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}};
    return p;
}

/* How far the shoulders are lifted at time t when they shrug: up 2 cm from 0.5 s to
   0.75 s and down again by 1 s (smoothstep). */
static double shrug(double t) {
    double u = t < 0.75 ? (t - 0.5) / 0.25 : (1.0 - t) / 0.25;
    if (u < 0.0) u = 0.0;
    if (u > 1.0) u = 1.0;
    return 0.02 * u * u * (3.0 - 2.0 * u);
}

int main(int argc, char **argv) {
    ShBatch *batch = NULL;
    double *grid = NULL;
    const char *npy = NULL;
    int shrugs = 0;
    double tolerance = 0.0;
    size_t samples = 0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "shrug") == 0) {
            shrugs = 1;
        } else if (strcmp(argv[i], "tolerance") == 0 && i + 1 < argc) {
            /* error-controlled steps with the contacts: each strand's local error below
               this, relative to its length */
            tolerance = strtod(argv[++i], NULL);
        } else if (strcmp(argv[i], "samples") == 0 && i + 1 < argc) {
            /* contact points per element (4 by default) */
            samples = (size_t)strtoul(argv[++i], NULL, 10);
        } else {
            npy = argv[i];
        }
    }

    /* the grid of signed distances, filled here (node (i, j, k) at i + NX (j + NY k)) */
    const double origin[3] = {BOX_CENTER[0] - BOX_HALF[0] - 3 * CELL,
                              BOX_CENTER[1] - BOX_HALF[1] - 3 * CELL,
                              BOX_CENTER[2] - BOX_HALF[2] - 3 * CELL};
    grid = malloc(sizeof(double) * NX * NY * NZ);
    if (grid == NULL) return 1;
    for (int k = 0; k < NZ; k++) {
        for (int j = 0; j < NY; j++) {
            for (int i = 0; i < NX; i++) {
                double p[3] = {origin[0] + CELL * i, origin[1] + CELL * j, origin[2] + CELL * k};
                grid[i + NX * (j + NY * k)] = box_distance(p);
            }
        }
    }
    if (npy != NULL && !write_npy(npy, grid)) {
        fprintf(stderr, "cannot write %s\n", npy);
        free(grid);
        return 1;
    }

    /* six strands rooted on the head sphere, each leaving it horizontally */
    const double where[STRANDS][3] = {{0.866, 0.0, 0.5},  {-0.866, 0.0, 0.5},
                                      {0.0, -0.866, 0.5}, {0.3, -0.8, 0.5},
                                      {0.8, 0.3, 0.5},    {-0.8, -0.3, 0.5}};
    const double along[STRANDS][3] = {{1, 0, 0}, {-1, 0, 0}, {0, -1, 0},
                                      {0, -1, 0}, {1, 0, 0},  {-1, 0, 0}};
    ShStrandParams params[STRANDS];
    memset(params, 0, sizeof params);
    for (int s = 0; s < STRANDS; s++) {
        ShStrandParams *p = &params[s];
        const double *u = where[s], *n0 = along[s];
        double len = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (int a = 0; a < 3; a++) p->root_position[a] = HEAD_RADIUS * u[a] / len;
        /* n0 along the strand, n1 up, n2 = n0 x n1 */
        const double n1[3] = {0.0, 0.0, 1.0};
        const double n2[3] = {n0[1] * n1[2] - n0[2] * n1[1], n0[2] * n1[0] - n0[0] * n1[2],
                              n0[0] * n1[1] - n0[1] * n1[0]};
        for (int a = 0; a < 3; a++) {
            p->root_frame[a] = n0[a];
            p->root_frame[3 + a] = n1[a];
            p->root_frame[6 + a] = n2[a];
        }
        p->elements = N;
        p->length = 0.25;
        p->cross_section.radius = 50e-6;
        p->cross_section.ellipticity = 1.0;
        p->cross_section.youngs_modulus = 1.5e9;
        p->cross_section.poisson_ratio = 0.48;
        p->cross_section.density = 1300.0;
        p->internal_friction = 5e-11;
        p->air_drag = 5e-6;
    }
    ShError error;
    ShStatus status = sh_batch_new(params, STRANDS, &batch, &error);
    if (status != SH_STATUS_OK) {
        fprintf(stderr, "sh_batch_new: %s\n  %s\n", sh_status_message(status), error.message);
        free(grid);
        return 1;
    }
    ShHeadState head;
    CHECK(sh_head_rest(&head));
    CHECK(sh_batch_set_head(batch, &head));
    const double gravity[3] = {0.0, 0.0, -9.81};
    CHECK(sh_batch_set_gravity(batch, gravity));

    /* the contacts: a scene's [contacts] defaults, with Coulomb friction */
    ShContactParams contact;
    CHECK(sh_contact_params_default(&contact));
    contact.friction = SH_FRICTION_COULOMB;
    contact.friction_coefficient = 0.3;
    contact.kinetic_friction_coefficient = 0.2;
    if (samples > 0) contact.samples_per_element = samples;
    CHECK(sh_batch_set_contacts(batch, &contact));
    if (tolerance > 0.0) CHECK(sh_batch_set_tolerance(batch, tolerance));

    /* the colliders: the head sphere, two shoulder capsules on poses of their own, the
       box's grid in the world (its values stay ours: they live until the batch is freed) */
    ShCollider colliders[4];
    memset(colliders, 0, sizeof colliders);
    colliders[0].kind = SH_COLLIDER_SPHERE;
    colliders[0].mount = SH_MOUNT_HEAD;
    colliders[0].shape.sphere.radius = HEAD_RADIUS;
    for (int c = 1; c <= 2; c++) {
        double side = c == 1 ? 1.0 : -1.0;
        colliders[c].kind = SH_COLLIDER_CAPSULE;
        colliders[c].mount = SH_MOUNT_POSE;
        ShCapsule capsule = {{0.07 * side, 0.0, -0.19}, {0.28 * side, 0.0, -0.23}, 0.045};
        colliders[c].shape.capsule = capsule;
    }
    colliders[3].kind = SH_COLLIDER_GRID;
    colliders[3].mount = SH_MOUNT_WORLD;
    colliders[3].shape.grid.values = grid;
    colliders[3].shape.grid.dims[0] = NX;
    colliders[3].shape.grid.dims[1] = NY;
    colliders[3].shape.grid.dims[2] = NZ;
    for (int a = 0; a < 3; a++) colliders[3].shape.grid.origin[a] = origin[a];
    colliders[3].shape.grid.spacing = CELL;
    CHECK(sh_batch_set_colliders(batch, colliders, 4));

    printf("# %d strands, N = %d, %d steps of 1/60 s, shoulders %s, tolerance %g\n", STRANDS,
           N, FRAMES, shrugs ? "shrugging" : "still", tolerance);
    printf("grid %d %d %d %.17g %.17g %.17g %.17g\n", NX, NY, NZ, origin[0], origin[1],
           origin[2], CELL);
    for (int s = 0; s < STRANDS; s++) {
        const double *r = params[s].root_position, *f = params[s].root_frame;
        printf("root %d %.17g %.17g %.17g\n", s, r[0], r[1], r[2]);
        printf("direction %d %.17g %.17g %.17g\n", s, f[0], f[1], f[2]);
    }

    /* the game loop */
    double points[3 * (N + 1)];
    for (int frame = 1; frame <= FRAMES; frame++) {
        double t0 = (frame - 1) * DT, t1 = frame * DT;
        ShPose start = lifted(shrugs ? shrug(t0) : 0.0), end = lifted(shrugs ? shrug(t1) : 0.0);
        for (size_t c = 1; c <= 2; c++) {
            CHECK(sh_batch_set_collider_pose(batch, c, &start, &end));
        }
        CHECK(sh_batch_step(batch, DT));
        double deepest[STRANDS];
        size_t touching[STRANDS];
        CHECK(sh_batch_contacts(batch, 0, STRANDS, deepest, touching));
        double worst = 0.0;
        size_t count = 0;
        for (int s = 0; s < STRANDS; s++) {
            if (deepest[s] > worst) worst = deepest[s];
            count += touching[s];
        }
        printf("deepest %d %.17g\ntouching %d %zu\n", frame, worst, frame, count);
        for (int s = 0; s < STRANDS; s++) {
            size_t written = 0;
            CHECK(sh_batch_centreline(batch, (size_t)s, points, N + 1, &written));
            for (size_t i = 0; i < written; i++) {
                printf("point %d %d %zu %.17g %.17g %.17g\n", frame, s, i, points[3 * i],
                       points[3 * i + 1], points[3 * i + 2]);
            }
        }
    }
    sh_batch_free(batch);
    free(grid);
    return 0;
}
