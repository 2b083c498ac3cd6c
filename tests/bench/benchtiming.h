/* Timing helpers shared by the benchmark programs: a monotonic clock in
 * nanoseconds, per-frame time series and their statistics, and JSON string
 * output. */
#pragma once

#include <stdlib.h>
#include <time.h>

#include <glib.h>

typedef struct
{
  const gchar *name;            /* "labsegment", ..., "chain", "copy" */
  gint64 *ns;                   /* per-frame times, sorted by summarise() */
  guint n;
  gdouble median_ms, p10_ms, p90_ms, mean_ms, min_ms, max_ms;
} Timing;

static inline gint64
now_ns (void)
{
  struct timespec ts;
  clock_gettime (CLOCK_MONOTONIC, &ts);
  return (gint64) ts.tv_sec * G_GINT64_CONSTANT (1000000000) + ts.tv_nsec;
}

static inline int
cmp_gint64 (const void *a, const void *b)
{
  const gint64 x = *(const gint64 *) a, y = *(const gint64 *) b;
  return x < y ? -1 : x > y;
}

/* Percentile q (0..1) of sorted values, interpolating between ranks. */
static inline gdouble
percentile (const gint64 * sorted, guint n, gdouble q)
{
  if (n == 0)
    return 0;
  const gdouble pos = q * (n - 1);
  const guint lo = (guint) pos;
  const guint hi = lo + 1 < n ? lo + 1 : lo;
  const gdouble frac = pos - lo;
  return sorted[lo] + frac * (sorted[hi] - sorted[lo]);
}

static inline void
summarise (Timing * t)
{
  gdouble sum = 0;
  qsort (t->ns, t->n, sizeof (gint64), cmp_gint64);
  for (guint i = 0; i < t->n; i++)
    sum += t->ns[i];
  t->median_ms = percentile (t->ns, t->n, 0.5) / 1e6;
  t->p10_ms = percentile (t->ns, t->n, 0.1) / 1e6;
  t->p90_ms = percentile (t->ns, t->n, 0.9) / 1e6;
  t->mean_ms = t->n ? sum / t->n / 1e6 : 0;
  t->min_ms = t->n ? t->ns[0] / 1e6 : 0;
  t->max_ms = t->n ? t->ns[t->n - 1] / 1e6 : 0;
}

/* Appends s to out as a JSON string literal. */
static inline void
json_string (GString * out, const gchar * s)
{
  g_string_append_c (out, '"');
  for (const guchar * p = (const guchar *) s; p && *p; p++) {
    if (*p == '"' || *p == '\\')
      g_string_append_printf (out, "\\%c", *p);
    else if (*p < 0x20)
      g_string_append_printf (out, "\\u%04x", *p);
    else
      g_string_append_c (out, *p);
  }
  g_string_append_c (out, '"');
}
