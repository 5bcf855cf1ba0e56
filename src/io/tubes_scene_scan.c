/* The scan scene (docs/scan.md): continuation in a model parameter, computed by one Fortran
 * procedure (src/workflow/tubes_scan.f90 scan_table, through the C API's tubes_parameter_scan, as Python's
 * Model.scan calls it through f2py); here only its table on stdout and the /scan group. */
#include "tubes.h"
#include "tubes_h5.h"
#include "tubes_scenes.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { SCAN_MAXFOLD = 32, MEQ = TUBES_SCAN_MAXEQ, MD = TUBES_MAXDOF };

static double wall(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* A name from its 8 ASCII codes (blank-padded) into buf[9]. */
static void name_of(const int *codes, char *buf) {
  int k;
  for (k = 0; k < 8; k++) buf[k] = (char)codes[k];
  buf[8] = 0;
  for (k = 7; k >= 0 && buf[k] == ' '; k--) buf[k] = 0;
}

/* The units of parameter ipar (1-based) of the run's model, from the library's table ("1" if none). */
static void param_units(const tubes_run_t *run, int ipar, char *buf, size_t n) {
  int ndof = 0, np = 0, si = 0, sd = 0;
  static char names[TUBES_MAXPARAM * TUBES_LPARAM], units[TUBES_MAXPARAM * TUBES_LUNITS],
      docs[TUBES_MAXPARAM * TUBES_LDOC];
  char summary[TUBES_LSUMMARY], lu[8], dsad[8], skind[8], surf[TUBES_LSUMMARY];
  double defs[TUBES_MAXPARAM], box[MD], boxc[MD], near[MD], sv, sa, gate;
  snprintf(buf, n, "1");
  if (tubes_model_info(run->system, &ndof, &np, names, defs, units, docs, summary, lu, box, boxc, dsad, near, skind,
                       &si, &sv, &sd, &sa, &gate, surf) < 0 || ipar < 1 || ipar > np)
    return;
  snprintf(buf, n, "%.*s", TUBES_LUNITS, units + TUBES_LUNITS * (ipar - 1));
}

int scene_scan(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int n = c->scan_n, m = n + 1, nde = c->scan_nde, nd1 = nde > 0 ? nde : 1, nd = run->ndof;
  int nseg = strcmp(c->orb_method, "multiple") ? 1 : c->orb_n_segments;
  size_t sm = (size_t)m;
  double *value = malloc(sizeof(double) * sm), *eq_q = malloc(sizeof(double) * MD * MEQ * sm),
         *eq_en = malloc(sizeof(double) * MEQ * sm), *sq = malloc(sizeof(double) * MD * sm),
         *sen = malloc(sizeof(double) * sm), *lam = malloc(sizeof(double) * sm),
         *om = malloc(sizeof(double) * (MD - 1) * sm), *per = malloc(sizeof(double) * nd1 * sm),
         *act = malloc(sizeof(double) * nd1 * sm), *stab = malloc(sizeof(double) * nd1 * sm);
  int *neq = malloc(sizeof(int) * sm), *res = malloc(sizeof(int) * sm), *eq_ix = malloc(sizeof(int) * MEQ * sm),
      *eq_nm = malloc(sizeof(int) * 8 * MEQ * sm), *eq_det = malloc(sizeof(int) * MEQ * sm),
      *sfound = malloc(sizeof(int) * sm), *conv = malloc(sizeof(int) * nd1 * sm),
      *rest = malloc(sizeof(int) * nd1 * sm);
  int pon = c->scan_p_trans != 0 && nde > 0;
  if (pon && run->law) {   /* the scan's model is the conservative one (scan_table) */
    fprintf(stderr, "%s: &scan p_trans: the scan follows the conservative model, and the dissipative model's (%s) "
            "p_trans is its transition region's: run the transition scene at the values of interest\n",
            run->input ? run->input : "tubes", run->dissip);
    return EXIT_BADINPUT;
  }
  double *pat = pon ? malloc(sizeof(double) * nd1 * sm) : NULL, *pae = pon ? malloc(sizeof(double) * nd1 * sm) : NULL,
         *ptr = pon ? malloc(sizeof(double) * nd1 * sm) : NULL;
  int *pst = pon ? malloc(sizeof(int) * nd1 * sm) : NULL;
  double fval[SCAN_MAXFOLD], fwid[SCAN_MAXFOLD], fq[MD * SCAN_MAXFOLD], ftol = 0;
  int fstep[SCAN_MAXFOLD], fkind[SCAN_MAXFOLD], fname[8 * SCAN_MAXFOLD], fpart[8 * SCAN_MAXFOLD], nf = 0;
  int rc = 0;
  if (!value || !eq_q || !eq_en || !sq || !sen || !lam || !om || !per || !act || !stab || !neq || !res || !eq_ix ||
      !eq_nm || !eq_det || !sfound || !conv || !rest || (pon && (!pat || !pae || !ptr || !pst))) {
    fprintf(stderr, "tubes: scan: out of memory (%d steps)\n", m);
    rc = EXIT_NUMERIC;
    goto out;
  }
  int ipar = c->scan_ipar;
  double start = 0, t0 = wall();
  tubes_scan_start(run->system, run->params, ipar, &start);   /* the reader resolved ipar: it has one */
  char pu[TUBES_LUNITS + 1];
  param_units(run, ipar, pu, sizeof pu);
  fprintf(stderr, "scan: %s from %.10g to %.10g in %d steps (saddle %s, %d orbit%s%s)...\n", c->scan_parameter, start,
          c->scan_to, n, run->saddle, nde, nde == 1 ? "" : "s", pon ? ", p_trans: a tube cut per step and dE" : "");
  /* the section of p_trans: the transition scene's (&section; tubes_scenes.c SECTION) */
  int ray = !strcmp(c->sec_kind, "ray");
  int skind = ray ? 1 : 2, sdir = ray ? c->sec_pth_sign : c->sec_direction;
  double slevel = ray ? c->sec_angle * M_PI / 180 : c->sec_value;
  int st = tubes_parameter_scan(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, ipar, c->scan_to, n, nde,
                      c->scan_de, nseg, c->orb_tol, c->orb_rtol, c->orb_atol, c->orb_max_iter, c->orb_n_samples,
                      run->method, c->h, c->omega_bind, strcmp(c->solver, "fixed_point") ? 1 : 2, c->max_iter, value,
                      neq, res, eq_q, eq_en, eq_ix, eq_nm, eq_det, sfound, sq, sen, lam, om, per, act, stab, conv,
                      rest, SCAN_MAXFOLD, &nf, fstep, fval, fwid, fkind, fq, fname, fpart, &ftol, pon, skind,
                      c->sec_index, slevel, sdir, c->tub_eps, c->tra_area_tol, c->tub_t_max, c->tub_n_init,
                      c->tub_n_max, pat, pae, ptr, pst);
  if (st < 0) {
    char msg[TUBES_LSTATUS];
    tubes_status_message(st, msg, sizeof msg);
    fprintf(stderr, "tubes: scan: failed: %s (status %d)%s\n", msg, st,
            st != TUBES_EINPUT ? ""
            : ipar > TUBES_SCAN_CONSTANT ? ": the formula's library with a value of the constant between the start "
                                           "and `to` was not built (the model line of this input with that value says "
                                           "why), or more than 64 equilibria lie in the box"
                                         : ": the model refuses a value of the parameter between the start and `to` "
                                           "(docs/models.md gives its range), or more than 64 equilibria lie in the box");
    rc = EXIT_NUMERIC;
    goto out;
  }
  /* the table: one row per step */
  printf("scan: %s from %.10g to %.10g%s%s in %d steps, saddle %s (%.2f s)\n", c->scan_parameter, start, c->scan_to,
         strcmp(pu, "1") ? " " : "", strcmp(pu, "1") ? pu : "", n, run->saddle, wall() - t0);
  printf("  %14s %4s %18s %14s %14s", c->scan_parameter, "n_eq", "E_saddle", "lambda", "omega");
  for (int i = 0; i < nde; i++) {
    char h[32];
    snprintf(h, sizeof h, "T(dE=%.4g)", c->scan_de[i]);
    printf("  %15s", h);
  }
  for (int i = 0; pon && i < nde; i++) {
    char h[32];
    snprintf(h, sizeof h, "p(dE=%.4g)", c->scan_de[i]);
    printf("  %15s", h);
  }
  printf("\n");
  int nlost = 0;
  for (int j = 0; j < m; j++) {
    printf("  %14.8g %4d%s", value[j], neq[j], res[j] ? "*" : " ");
    if (sfound[j])
      printf("%17.10g %14.8g %14.8g", sen[j], lam[j], nd > 1 ? om[(MD - 1) * j] : NAN);
    else
      printf("%17s %14s %14s", "(no saddle)", "-", "-");
    for (int i = 0; i < nde; i++) {
      if (conv[nd1 * j + i]) printf("  %15.10g", per[nd1 * j + i]);
      else printf("  %15s", "-");
      nlost += sfound[j] && !conv[nd1 * j + i];   /* past a fold that took the saddle: none to find */
    }
    for (int i = 0; pon && i < nde; i++) {
      if (!isnan(ptr[nd1 * j + i])) printf("  %15.10g", ptr[nd1 * j + i]);
      else printf("  %15s", "-");
      nlost += sfound[j] && pst[nd1 * j + i] < 0;
    }
    printf("\n");
  }
  for (int j = 0; pon && j < m; j++)
    for (int i = 0; i < nde; i++)
      if (sfound[j] && pst[nd1 * j + i] < 0) {
        char msg[TUBES_LSTATUS];
        tubes_status_message(pst[nd1 * j + i], msg, sizeof msg);
        fprintf(stderr, "tubes: scan: p_trans at %s = %.10g, dE = %g failed: %s (status %d; the transition scene "
                "at that value says more)\n", c->scan_parameter, value[j], c->scan_de[i], msg, pst[nd1 * j + i]);
      }
  if (nf == 0) printf("  no fold between %.10g and %.10g (equilibria continued by Newton; * a new search)\n", start,
                      c->scan_to);
  for (int k = 0; k < nf && k < SCAN_MAXFOLD; k++) {
    char a[9], b[9];
    name_of(fname + 8 * k, a);
    name_of(fpart + 8 * k, b);
    if (fkind[k] == 3)
      printf("  %s = %.15g (+- %.1e): %s leaves the search box at q = (", c->scan_parameter, fval[k], 0.5 * fwid[k], a);
    else
      printf("  fold: %s = %.15g (+- %.1e): %s %s %s at q = (", c->scan_parameter, fval[k], 0.5 * fwid[k], a,
             fkind[k] == 1 ? "meets" : "changes its index near", b[0] ? b : "(none)");
    for (int d = 0; d < nd; d++) printf("%s%.8g", d ? ", " : "", fq[MD * k + d]);
    printf(")\n");
  }
  if (nf > SCAN_MAXFOLD) printf("  %d folds found, the first %d recorded\n", nf, SCAN_MAXFOLD);
  /* /scan */
  hid_t g = h5_group(run->file, "scan");
  int e = g < 0;
  if (!e) {
    hsize_t dm = sm, d2[2] = {sm, (hsize_t)(MD - 1)}, dq[3] = {sm, MEQ, MD}, de2[2] = {sm, MEQ},
            dsq[2] = {sm, MD}, dor[2] = {sm, (hsize_t)nde}, nfr = (hsize_t)(nf < SCAN_MAXFOLD ? nf : SCAN_MAXFOLD),
            dfq[2] = {nfr, MD};
    double *orow = malloc(sizeof(double) * (nde ? nde : 1) * sm);
    int *irow = malloc(sizeof(int) * (nde ? nde : 1) * sm);
    e |= !orow || !irow;
    e |= h5_write_double(g, "value", 1, &dm, value, pu);
    e |= h5_write_int(g, "n_equilibria", dm, neq, NULL);
    e |= h5_write_int(g, "researched", dm, res, NULL);
    e |= h5_write_double(g, "eq_q", 3, dq, eq_q, NULL);
    e |= h5_write_double(g, "eq_energy", 2, de2, eq_en, NULL);
    e |= h5_write_int_nd(g, "eq_index", 2, de2, eq_ix, NULL);
    e |= h5_write_int_nd(g, "eq_det", 2, de2, eq_det, NULL);
    e |= h5_write_int(g, "saddle_found", dm, sfound, NULL);
    e |= h5_write_double(g, "saddle_q", 2, dsq, sq, NULL);
    e |= h5_write_double(g, "saddle_energy", 1, &dm, sen, NULL);
    e |= h5_write_double(g, "lambda", 1, &dm, lam, NULL);
    e |= h5_write_double(g, "omega", 2, d2, om, NULL);
    /* the names, "W1 S12 ..." per step */
    char **names = calloc(sm, sizeof(char *));
    e |= !names;
    for (int j = 0; names && j < m; j++) {
      names[j] = calloc(9 * MEQ + 1, 1);
      if (!names[j]) {
        e = 1;
        break;
      }
      for (int k = 0; k < neq[j]; k++) {
        char a[9];
        name_of(eq_nm + 8 * (MEQ * j + k), a);
        snprintf(names[j] + strlen(names[j]), 9 * MEQ + 1 - strlen(names[j]), "%s%s", k ? " " : "", a);
      }
    }
    if (!e) e |= h5_write_strings(g, "eq_names", sm, (const char *const *)names);
    for (int j = 0; names && j < m; j++) free(names[j]);
    free(names);
    if (nde > 0 && !e) {
      e |= h5_write_double(g, "dE", 1, &dor[1], c->scan_de, NULL);
      double *src[3] = {per, act, stab};
      const char *dn[3] = {"period", "action", "stability_index"};
      for (int q = 0; q < 3; q++) {
        for (int j = 0; j < m; j++)
          for (int i = 0; i < nde; i++) orow[(size_t)nde * j + i] = src[q][(size_t)nd1 * j + i];
        e |= h5_write_double(g, dn[q], 2, dor, orow, NULL);
      }
      int *isrc[2] = {conv, rest};
      const char *in[2] = {"converged", "restarted"};
      for (int q = 0; q < 2; q++) {
        for (int j = 0; j < m; j++)
          for (int i = 0; i < nde; i++) irow[(size_t)nde * j + i] = isrc[q][(size_t)nd1 * j + i];
        e |= h5_write_int_nd(g, in[q], 2, dor, irow, NULL);
      }
      if (pon) {   /* p_trans along the scan (docs/output.md) */
        double *psrc[3] = {ptr, pat, pae};
        const char *pn[3] = {"p_trans", "A_tube", "A_E"};
        for (int q = 0; q < 3; q++) {
          for (int j = 0; j < m; j++)
            for (int i = 0; i < nde; i++) orow[(size_t)nde * j + i] = psrc[q][(size_t)nd1 * j + i];
          e |= h5_write_double(g, pn[q], 2, dor, orow, NULL);
        }
        for (int j = 0; j < m; j++)
          for (int i = 0; i < nde; i++) irow[(size_t)nde * j + i] = pst[(size_t)nd1 * j + i];
        e |= h5_write_int_nd(g, "p_trans_status", 2, dor, irow, NULL);
      }
    }
    free(orow);
    free(irow);
    hid_t fg = h5_group(g, "folds");
    e |= fg < 0;
    if (fg >= 0) {
      const char *fn[SCAN_MAXFOLD], *fp[SCAN_MAXFOLD];
      char fnb[SCAN_MAXFOLD][9], fpb[SCAN_MAXFOLD][9];
      for (hsize_t k = 0; k < nfr; k++) {
        name_of(fname + 8 * k, fnb[k]);
        name_of(fpart + 8 * k, fpb[k]);
        fn[k] = fnb[k];
        fp[k] = fpb[k];
      }
      e |= h5_write_double(fg, "value", 1, &nfr, fval, pu);
      e |= h5_write_double(fg, "bracket", 1, &nfr, fwid, pu);
      e |= h5_write_int(fg, "kind", nfr, fkind, NULL);
      int rows[SCAN_MAXFOLD];   /* 0-based: the first row after the fold */
      for (hsize_t k = 0; k < nfr; k++) rows[k] = fstep[k] - 1;
      e |= h5_write_int(fg, "step", nfr, rows, NULL);
      e |= h5_write_double(fg, "q", 2, dfq, fq, NULL);
      if (nfr > 0) {
        e |= h5_write_strings(fg, "name", nfr, fn);
        e |= h5_write_strings(fg, "partner", nfr, fp);
      }
      e |= h5_attr_long(fg, "n_found", nf);
      e |= h5_attr_double(fg, "tol", ftol);
      H5Gclose(fg);
    }
    e |= h5_attr_string(g, "parameter", c->scan_parameter);
    e |= h5_attr_double(g, "start", start);
    e |= h5_attr_double(g, "to", c->scan_to);
    e |= h5_attr_long(g, "n", n);
    e |= h5_attr_string(g, "saddle", run->saddle);
    e |= h5_attr_string(g, "parameter_units", h5_units(pu));
    H5Gclose(g);
  }
  if (e) rc = EXIT_IO;
  else if (nlost) rc = EXIT_PARTIAL;
out:
  free(value); free(eq_q); free(eq_en); free(sq); free(sen); free(lam); free(om); free(per); free(act); free(stab);
  free(neq); free(res); free(eq_ix); free(eq_nm); free(eq_det); free(sfound); free(conv); free(rest);
  free(pat); free(pae); free(ptr); free(pst);
  return rc;
}
