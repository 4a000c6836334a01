/* Preloaded into KiCad worker processes (LD_PRELOAD) to cut KiCad's polling sleeps short.
 *
 * KiCad 9.0.8's DRC waits for its track-clearance tasks with
 *     while( done < count ) { reportProgress(); if( cancelled ) ...; sleep_for( 250ms ); }
 * (inlined std::this_thread::sleep_for = nanosleep), so a DRC of a routed board sleeps about
 * 250 ms after its threads have finished. A long nanosleep called from KiCad's own code is
 * turned into a 1 ms one: the caller loops until its condition holds, so waking it early only
 * makes it notice sooner. Sleeps from anywhere else (Python, wxWidgets, libstdc++) and sleeps
 * shorter than 100 ms are passed through unchanged. Evidence: DEVELOPERS.md, "KiCad's DRC
 * polling wait".
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdatomic.h>
#include <string.h>
#include <time.h>

#define LONG_SLEEP_NS 100000000L /* only sleeps this long or longer are polls worth cutting */
#define POLL_NS 1000000L         /* what a cut sleep lasts */

typedef int (*nanosleep_fn)(const struct timespec *, struct timespec *);

static nanosleep_fn real_nanosleep;
static atomic_ulong shortened;

__attribute__((constructor)) static void resolve_real_nanosleep(void)
{
    real_nanosleep = (nanosleep_fn)dlsym(RTLD_NEXT, "nanosleep");
}

static int is_long(const struct timespec *req)
{
    return req->tv_sec > 0 || req->tv_nsec >= LONG_SLEEP_NS;
}

/* KiCad's in-process modules, by file name: _pcbnew.so / _pcbnew.kiface, libkicommon,
 * libkigal, libkicad_*. Only _pcbnew calls nanosleep directly in 9.0.8. */
static int is_kicad_code(const void *address)
{
    Dl_info info;
    if (!dladdr(address, &info) || info.dli_fname == NULL)
        return 0;
    const char *slash = strrchr(info.dli_fname, '/');
    const char *name = slash ? slash + 1 : info.dli_fname;
    return strncmp(name, "_pcbnew.", 8) == 0 || strncmp(name, "libkicommon.", 12) == 0
        || strncmp(name, "libkigal.", 9) == 0 || strncmp(name, "libkicad_", 9) == 0;
}

int nanosleep(const struct timespec *req, struct timespec *rem)
{
    if (real_nanosleep == NULL) /* called before our constructor ran */
        resolve_real_nanosleep();
    if (req != NULL && req->tv_nsec >= 0 && req->tv_nsec < 1000000000L && is_long(req)
        && is_kicad_code(__builtin_return_address(0))) {
        struct timespec poll = {0, POLL_NS};
        atomic_fetch_add(&shortened, 1);
        /* An interrupted poll reports EINTR with its own remainder, as a 1 ms sleep would. */
        return real_nanosleep(&poll, rem);
    }
    return real_nanosleep(req, rem);
}

/* How many sleeps this process has cut short: lets tests check the library is active. */
unsigned long pcbdata_fastwait_shortened(void)
{
    return atomic_load(&shortened);
}
