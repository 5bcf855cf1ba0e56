# The registered namelist variables: one annotated field of tubes_config_t each
# (src/workflow/tubes_config.f90), from which the build writes everything else a variable needs
# (docs/development.md, "Adding a namelist variable"). Run by the Makefile:
#   awk -v dir=build/include -f src/io/tubes_registry_gen.awk src/workflow/tubes_config.f90
# An annotation is a comment line right before the field's declaration (one field, real(c_double),
# integer(c_int), integer(c_int64_t), a logical (integer(c_int) 0/1) or a string
# character(kind=c_char) :: FIELD(LENGTH)):
#   !@ &GROUP NAME | UNITS | DEFAULT | ALLOWED | TEXT
#   real(c_double) :: FIELD
# ALLOWED is the reader's check and the text of its message: "LO .. HI" (both included), "> LO",
# ">= LO", "< HI", "<= HI", "LO OP SYMBOL OP HI" (OP < or <=: "0 <= zeta < 1"), "finite", or for
# an integer its values separated by ", " when they are consecutive ("-1, 0, 1"); DEFAULT a number.
# A string (character(kind=c_char) :: FIELD(LENGTH)): DEFAULT quoted ('stable'), ALLOWED its values
# separated by ", " (stable, unstable, both), the reader's check. A logical (integer(c_int), 1 for
# .true.; the namelist's variable a LOGICAL): DEFAULT .true. or .false., ALLOWED only text (the
# lexer checks the value). A list of excess energies (real(c_double) :: X_de(MAXDE), its count the
# field X_nde): ALLOWED "> 0, increasing" (the reader's check_list), DEFAULT its numbers separated
# by ", " (--help shows more than five as "1, 2, 5, ..., 700, 750") or "the &GROUP list" (that
# group's registered list, annotated before it: then checked only where the file sets it, and its
# per-model rule is that list's). A number's or a list's DEFAULT may be one model's:
# "MODEL: VALUE; other models: required" (VALUE stored as the default; --help "VALUE (MODEL; other
# models: required)"; the run refuses other models without the variable: nml_defaults.inc). A
# hand-written variable's per-model default is a mark that carries it:
#   !@ &GROUP NAME | default MODEL: VALUE; other models: required
# (the rule, and TUBES_REGISTRY_DEFAULT_<GROUP>_<NAME>, --help's text, for its table row). The group's registered
# variables keep their annotations' order, in the namelist, in the effective namelist and in
# --help. A variable written by hand that stands between registered ones in its group's order is
# named by an annotation without '|' (!@ &GROUP NAME: a mark, no field follows it): it ends the
# group's run of registered variables, and the next ones make run 2, 3, ... Run 1 stands where
# tubes_nml.f90 includes nml_<group>_decl.inc and tubes_input.c's table puts
# TUBES_REGISTRY_ROWS_<GROUP>, run K where they put nml_<group>_decl_K.inc and
# TUBES_REGISTRY_ROWS_<GROUP>_K. It writes into dir:
#   tubes_registry.h        C: each run's rows of the reader's table (TUBES_REGISTRY_ROWS_<GROUP>[_K]:
#                           tubes_input.c tubes_nml_vars, --help, messages), each range with the
#                           field's offset (nml_validate's check), each string's values, each
#                           list's offsets
#   nml_vars.inc            Fortran: the fields of tubes_nml's vars_t with their defaults
#   nml_to_c.inc, nml_from_c.inc   the copies between vars_t and tubes_config_t
#   nml_GROUP_decl[_K].inc, nml_GROUP_in.inc, nml_GROUP_out.inc   per group of GROUPS: the namelist
#                           variables of a run and their place in the group, the copies in and out of vars_t
#   nml_defaults.inc        Fortran (included by src/workflow/tubes_setup.f90): default_given(model, group,
#                           name), whether model has the default, and default_text(group, name), its value
#   nml_GROUP_io.inc        the copies in, the group's READ (mode 'r') or WRITE, the copies out: the
#                           whole io_GROUP of tubes_nml where no other statement stands between them
# A group not in GROUPS (run, model, section: their reading or writing has rules of its own) or a declaration
# it cannot read stops the build.
BEGIN {
  ng = split("equilibria trajectory integrator orbits tubes transition montecarlo sections experiment flux scan", groups, " ")
  for (i = 1; i <= ng; i++) known[groups[i]] = 1
  n = 0
}
function fail(msg) { printf "tubes_registry_gen: %s:%d: %s\n", FILENAME, FNR, msg > "/dev/stderr"; bad = 1; exit 1 }
function trim(s) { gsub(/^[ \t]+|[ \t]+$/, "", s); return s }
function cstr(s) { gsub(/\\/, "\\\\", s); gsub(/"/, "\\\"", s); return "\"" s "\"" }
/^[ \t]*!@/ {
  s = $0; sub(/^[ \t]*!@[ \t]*/, "", s)
  m = split(s, f, "|")
  if (m == 1 && split(trim(s), gn, /[ \t]+/) == 2 && substr(gn[1], 1, 1) == "&") {   # a hand-written variable: a run ends
    pg = substr(gn[1], 2)
    if (!(pg in known)) fail("group &" pg " takes no registered variable (allowed: " join() ")")
    if (runlen[pg, run[pg] + 0] > 0) run[pg]++
    next
  }
  if (m == 2 && split(trim(f[1]), gn, /[ \t]+/) == 2 && substr(gn[1], 1, 1) == "&" && trim(f[2]) ~ /^default /) {
    # a hand-written variable's per-model default: a mark (its run ends) whose default joins the rule
    pg = substr(gn[1], 2)
    if (!(pg in known)) fail("group &" pg " takes no registered variable (allowed: " join() ")")
    if (runlen[pg, run[pg] + 0] > 0) run[pg]++
    pd = trim(f[2]); sub(/^default /, "", pd)
    if (!per_model(pd)) fail("a mark's default '" pd "' is not 'MODEL: VALUE; other models: required'")
    nh++; HG[nh] = pg; HN[nh] = gn[2]; HM[nh] = pm_model; HV[nh] = pm_value
    HS[nh] = pm_value " (" pm_model "; other models: required)"
    next
  }
  if (m < 5) fail("an annotation has 5 fields separated by |: &group name | units | default | allowed | text")
  for (k = 6; k <= m; k++) f[5] = f[5] "|" f[k]   # the text, the last field, may hold a | (|H - E|/E)
  split(trim(f[1]), gn, /[ \t]+/)
  if (substr(gn[1], 1, 1) != "&" || gn[2] == "") fail("an annotation starts with &group name")
  pg = substr(gn[1], 2); pn = gn[2]
  if (!(pg in known)) fail("group &" pg " takes no registered variable (allowed: " join() ")")
  pu = trim(f[2]); pd = trim(f[3]); pa = trim(f[4]); pt = trim(f[5])
  pending = 1
  next
}
pending {
  line = $0; sub(/!.*/, "", line)
  if (!match(line, /::/)) fail("an annotation is followed by the field's declaration")
  type = substr(line, 1, RSTART - 1); field = trim(substr(line, RSTART + 2)); gsub(/[ \t]/, "", type)
  len = ""
  if ((type == "character(kind=c_char)" || type == "real(c_double)") && match(field, /^[A-Za-z_][A-Za-z_0-9]*\([A-Z]+\)$/)) {
    len = field; sub(/^[^(]*\(/, "", len); sub(/\)$/, "", len); sub(/\(.*/, "", field)
  }
  if (field ~ /[,(]/) fail("an annotated declaration declares one scalar field (or one string or list, NAME(LENGTH))")
  pmodel = ""   # a per-model default: the value is that model's, the variable required for the others
  if (per_model(pd)) { pmodel = pm_model; pd = pm_value }
  isint = 0; isstr = 0; islog = 0; islist = 0; shown = pd; cnt = ""; fdl = ""; lset = 0
  if (len != "" && type == "real(c_double)") {   # a list of excess energies and its count
    if (pa != "> 0, increasing") fail("a list's allowed is '> 0, increasing' (the reader's check_list), not '" pa "'")
    cnt = field; sub(/_[^_]*$/, "", cnt); cnt = cnt "_n" substr(field, length(cnt) + 2)   # tub_de: tub_nde
    if (pd ~ /^[-+0-9.eE]+(, [-+0-9.eE]+)*$/) {
      nv = split(pd, r, /, /); fdl = ""
      for (k = 1; k <= nv; k++)   # four a line: Fortran's lines end at 132 characters
        fdl = fdl (k == 1 ? "" : k % 4 == 1 ? ", &\n      " : ", ") r[k] (r[k] ~ /[.eE]/ ? "" : ".0") "_c_double"
      fdl = "[" fdl "]"
      if (nv > 5) shown = r[1] ", " r[2] ", " r[3] ", ..., " r[nv - 1] ", " r[nv]   # --help's text
    } else if (match(pd, /^the &[a-z]+ list$/)) {   # another group's list: checked only where the file sets this one
      og = substr(pd, 6); sub(/ list$/, "", og)
      for (k = 1; k <= n; k++) if (G[k] == og && LIST[k]) { fdl = "cfg%" F[k] "(1:cfg%" CNT[k] ")"; pmodel = PM[k] }
      if (fdl == "") fail("the list of &" og " is not registered before this one")
      lset = 1
    } else fail("a list's default '" pd "' is neither numbers separated by ', ' nor 'the &group list'")
    ct = "NML_REAL"; ft = "real(c_double), allocatable"; fd = "UNSET"; islist = 1
  } else if (len != "") {
    if (pd !~ /^'[^']*'$/) fail("a string's default " pd " is not quoted ('...')")
    if (pa !~ /^[^,]+(, [^,]+)*$/) fail("a string's allowed '" pa "' is not its values separated by ', '")
    ct = "NML_STRING"; ft = "character(" len ")"; fd = pd; isstr = 1
  } else if (type == "integer(c_int)" && (pd == ".true." || pd == ".false.")) {
    ct = "NML_LOGICAL"; ft = "logical"; fd = pd; islog = 1
  } else if (pd !~ /^[-+]?[0-9.]+([eE][-+]?[0-9]+)?$/) fail("default '" pd "' is not a number (or .true., .false. for a logical)")
  else if (type == "real(c_double)") { ct = "NML_REAL"; ft = "real(c_double)"; fd = pd (pd ~ /[.eE]/ ? "" : ".0") "_c_double" }
  else if (type == "integer(c_int)") {
    if (pd !~ /^[-+]?[0-9]+$/) fail("an integer's default '" pd "' is not an integer")
    ct = "NML_INT"; ft = "integer"; fd = pd; isint = 1
  }
  else if (type == "integer(c_int64_t)") {
    if (pd !~ /^[-+]?[0-9]+$/) fail("an integer's default '" pd "' is not an integer")
    ct = "NML_INT"; ft = "integer(c_int64_t)"; fd = pd "_c_int64_t"; isint = 2
  }
  else fail("type " type " is not registered (real(c_double), integer(c_int), integer(c_int64_t), character(kind=c_char) NAME(LENGTH))")
  lo = "-INFINITY"; hi = "INFINITY"; lo_open = 0; hi_open = 0; alt = 0; altok = 0; even = 0; lof = ""
  a = pa
  if (!isstr && !islog && !islist) {
    if (isint && match(a, /^[-+]?[0-9]+, or (even )?[-+]?[0-9]+ \.\. [-+]?[0-9]+/)) {   # "V, or [even] LO .. HI[ RULE]"
      a = substr(a, 1, RLENGTH); split(a, r, /, or /); alt = r[1]; altok = 1; a = r[2]
      if (a ~ /^even /) { even = 1; a = substr(a, 6) }
    } else if (!(isint && a ~ /^[-+]?[0-9]+(, [-+]?[0-9]+)+$/) && index(a, ", "))
      a = substr(a, 1, index(a, ", ") - 1)   # "FORM, RULE": the rule is another check's, kept by hand
    if (match(a, /^[a-z_][a-z_0-9]* \.\. [-+0-9.eE]+$/)) {   # "OTHER .. HI": bounded below by the group's OTHER
      split(a, r, / \.\. /); a = "-INFINITY .. " r[2]
      for (k = 1; k <= n; k++) if (G[k] == pg && N[k] == r[1] && !STR[k] && !LOG[k] && !LIST[k]) lof = F[k]
      if (lof == "") fail("allowed '" pa "': " r[1] " is not a number registered before " pn " in &" pg)
      for (k = 1; k <= n; k++) if (F[k] == lof && INT[k] != isint) fail("allowed '" pa "': " r[1] " is not of " pn "'s type")
    }
  }
  if (isstr || islog || islist) ;
  else if (isint && a ~ /^[-+]?[0-9]+(, [-+]?[0-9]+)+$/) {   # an integer's values: consecutive, a range
    nv = split(a, r, /, /); lo = r[1] + 0; hi = r[nv] + 0
    for (k = 2; k <= nv; k++) if (r[k] + 0 != r[k - 1] + 1) fail("an integer's values '" a "' are not consecutive")
  }
  else if (a == "finite") { lo = "-DBL_MAX"; hi = "DBL_MAX" }   # an infinity is not finite
  else if (match(a, /^([-+0-9.eE]+|-INFINITY) \.\. [-+0-9.eE]+$/)) { split(a, r, / \.\. /); lo = r[1]; hi = r[2] }
  else if (a ~ /^>= /) lo = substr(a, 4)
  else if (a ~ /^> /) { lo = substr(a, 3); lo_open = 1 }
  else if (a ~ /^<= /) hi = substr(a, 4)
  else if (a ~ /^< /) { hi = substr(a, 3); hi_open = 1 }
  else if (split(a, r, / /) == 5 && r[1] ~ /^[-+0-9.eE]+$/ && r[5] ~ /^[-+0-9.eE]+$/ && r[3] ~ /^[A-Za-z_][A-Za-z_0-9]*$/ &&
           (r[2] == "<" || r[2] == "<=") && (r[4] == "<" || r[4] == "<=")) {
    lo = r[1]; hi = r[5]; lo_open = (r[2] == "<"); hi_open = (r[4] == "<")
  }
  else fail("allowed '" a "' is not one of: LO .. HI, > LO, >= LO, < HI, <= HI, LO <= X < HI (< or <=), finite")
  if (pmodel != "" && (isstr || islog)) fail("a per-model default is a number's or a list's")
  if (pmodel != "" && !lset) shown = shown " (" pmodel "; other models: required)"
  n++
  G[n] = pg; N[n] = pn; U[n] = pu; D[n] = pd; A[n] = pa; T[n] = pt; F[n] = field; CT[n] = ct; FT[n] = ft; FD[n] = fd
  LO[n] = lo; HI[n] = hi; LOO[n] = lo_open; HIO[n] = hi_open; INT[n] = isint; STR[n] = isstr; LOG[n] = islog
  ALT[n] = alt; ALTOK[n] = altok; EVEN[n] = even; LOF[n] = lof
  LIST[n] = islist; LEN[n] = len; CNT[n] = cnt; FDL[n] = fdl; LSET[n] = lset; SHOWN[n] = shown; PM[n] = pmodel
  R[n] = run[pg] + 0; runlen[pg, R[n]]++; if (R[n] > nrun[pg]) nrun[pg] = R[n]
  pending = 0
  next
}
# DEFAULT "MODEL: VALUE; other models: required" (one model's value: the reader stores one default):
# 1 with pm_model and pm_value set, else 0
function per_model(d,   p) {
  if (!match(d, /^[a-z][a-z0-9_]*: [^;]+; other models: required$/)) return 0
  p = index(d, ":"); pm_model = substr(d, 1, p - 1); pm_value = substr(d, p + 2)
  sub(/; other models: required$/, "", pm_value)
  return 1
}
function sfx(k) { return k ? "_" (k + 1) : "" }   # a group's run r (0: the first) in the generated names
function join(   s, i) { s = ""; for (i = 1; i <= ng; i++) s = s (i > 1 ? ", " : "") groups[i]; return s }
END {
  if (bad) exit 1
  if (pending) { print "tubes_registry_gen: an annotation without its field" > "/dev/stderr"; exit 1 }
  h = dir "/tubes_registry.h"
  print "/* Generated by src/io/tubes_registry_gen.awk from src/workflow/tubes_config.f90: do not edit. */" > h
  for (j = 1; j <= ng; j++) {
    g = groups[j]
    for (rr = 0; rr <= nrun[g]; rr++) {
      printf "#define TUBES_REGISTRY_ROWS_%s%s", toupper(g), sfx(rr) > h
      for (i = 1; i <= n; i++)
        if (G[i] == g && R[i] == rr)
          printf " \\\n  {%s, %s, %s, %s, %s, %s, %s, %s},", cstr(G[i]), cstr(N[i]), CT[i], LIST[i] ? "TUBES_" LEN[i] : 1,
                 cstr(U[i]), cstr(SHOWN[i]),
                 cstr(A[i]), cstr(T[i]) > h
      print "" > h
    }
  }
  nr = 0; ns = 0
  printf "#define TUBES_REGISTRY_RANGES" > h
  for (i = 1; i <= n; i++)
    if (!STR[i] && !LOG[i] && !LIST[i]) {
      printf " \\\n  {%s, %s, offsetof(tubes_config_t, %s), %d, %s, %s, %d, %d, %s, %d, %s, %d},", cstr(G[i]), cstr(N[i]),
             F[i], INT[i], LO[i], HI[i], LOO[i], HIO[i], LOF[i] == "" ? "-1" : "(long)offsetof(tubes_config_t, " LOF[i] ")",
             ALTOK[i], ALT[i], EVEN[i] > h
      nr++
    }
  if (nr == 0) printf " \\\n  {NULL, NULL, 0, 0, 0, 0, 0, 0, -1, 0, 0, 0}," > h
  print "" > h
  printf "#define TUBES_REGISTRY_STRINGS" > h    # a string's values: its allowed text, ", " between them
  for (i = 1; i <= n; i++)
    if (STR[i]) {
      printf " \\\n  {%s, %s, offsetof(tubes_config_t, %s), %s},", cstr(G[i]), cstr(N[i]), F[i], cstr(A[i]) > h
      ns++
    }
  if (ns == 0) printf " \\\n  {NULL, NULL, 0, NULL}," > h
  print "" > h
  nl = 0
  printf "#define TUBES_REGISTRY_LISTS" > h   # a list: its values' and its count's offsets, checked only when set
  for (i = 1; i <= n; i++)
    if (LIST[i]) {
      printf " \\\n  {%s, %s, offsetof(tubes_config_t, %s), offsetof(tubes_config_t, %s), %d},", cstr(G[i]), cstr(N[i]),
             F[i], CNT[i], LSET[i] > h
      nl++
    }
  if (nl == 0) printf " \\\n  {NULL, NULL, 0, 0, 0}," > h
  print "" > h
  printf "enum { TUBES_REGISTRY_N = %d, TUBES_REGISTRY_NS = %d, TUBES_REGISTRY_NL = %d };\n", nr, ns, nl > h
  for (i = 1; i <= nh; i++)   # a hand-written variable's per-model default, as --help shows it (its table row)
    printf "#define TUBES_REGISTRY_DEFAULT_%s_%s %s\n", toupper(HG[i]), toupper(HN[i]), cstr(HS[i]) > h
  # the per-model defaults' rule (src/workflow/tubes_setup.f90 includes it: default_refused)
  pmf = dir "/nml_defaults.inc"
  print "! Generated by src/io/tubes_registry_gen.awk from src/workflow/tubes_config.f90: do not edit." > pmf
  print "" > pmf
  print "  !> Whether model has the registry's default of &group name: .false. where that default is one" > pmf
  print "  !> model's (annotation DEFAULT 'MODEL: VALUE; other models: required') and model is another, so" > pmf
  print "  !> the variable must be given; .true. where the default is every model's (or none is registered)." > pmf
  print "  pure logical function default_given(model, group, name) result(given)" > pmf
  print "    character(*), intent(in) :: model, group, name" > pmf
  print "    given = .true." > pmf
  for (i = 1; i <= n; i++)
    if (PM[i] != "")
      printf "    if (group == '%s' .and. name == '%s') given = model == '%s'\n", G[i], N[i], PM[i] > pmf
  for (i = 1; i <= nh; i++)
    printf "    if (group == '%s' .and. name == '%s') given = model == '%s'\n", HG[i], HN[i], HM[i] > pmf
  print "  end function default_given" > pmf
  print "" > pmf
  print "  !> The value of the registry's per-model default of &group name, as its annotation writes it ('': none)." > pmf
  print "  pure function default_text(group, name) result(text)" > pmf
  print "    character(*), intent(in) :: group, name" > pmf
  print "    character(:), allocatable :: text" > pmf
  print "    text = ''" > pmf
  for (i = 1; i <= n; i++)
    if (PM[i] != "" && !LSET[i])
      printf "    if (group == '%s' .and. name == '%s') text = '%s'\n", G[i], N[i], D[i] > pmf
  for (i = 1; i <= nh; i++)
    printf "    if (group == '%s' .and. name == '%s') text = '%s'\n", HG[i], HN[i], HV[i] > pmf
  print "  end function default_text" > pmf
  close(pmf)
  v = dir "/nml_vars.inc"; tc = dir "/nml_to_c.inc"; fc = dir "/nml_from_c.inc"
  print "! Generated by src/io/tubes_registry_gen.awk: do not edit." > v
  print "! Generated by src/io/tubes_registry_gen.awk: do not edit." > tc
  print "! Generated by src/io/tubes_registry_gen.awk: do not edit." > fc
  for (i = 1; i <= n; i++) {
    if (LIST[i]) {
      printf "    real(c_double) :: %s(%s) = UNSET\n", F[i], LEN[i] > v
      printf "    call put_list(v%%%s, cfg%%%s, cfg%%%s, %s)\n", F[i], F[i], CNT[i], FDL[i] > tc
      printf "    v%%%s = cfg%%%s\n", F[i], F[i] > fc
      continue
    }
    printf "    %s :: %s = %s\n", FT[i], F[i], FD[i] > v
    if (STR[i]) {
      printf "    call f_to_c(v%%%s, cfg%%%s)\n", F[i], F[i] > tc
      printf "    v%%%s = c_to_f(cfg%%%s)\n", F[i], F[i] > fc
    } else if (LOG[i]) {
      printf "    cfg%%%s = merge(1, 0, v%%%s)\n", F[i], F[i] > tc
      printf "    v%%%s = cfg%%%s /= 0\n", F[i], F[i] > fc
    } else {
      printf "    cfg%%%s = v%%%s\n", F[i], F[i] > tc
      printf "    v%%%s = cfg%%%s\n", F[i], F[i] > fc
    }
  }
  for (j = 1; j <= ng; j++) {
    g = groups[j]
    di = dir "/nml_" g "_in.inc"; do_ = dir "/nml_" g "_out.inc"; rw = dir "/nml_" g "_io.inc"
    print "! Generated by src/io/tubes_registry_gen.awk: do not edit." > di
    print "! Generated by src/io/tubes_registry_gen.awk: do not edit." > do_
    print "! Generated by src/io/tubes_registry_gen.awk: do not edit." > rw
    for (rr = 0; rr <= nrun[g]; rr++) {
      de = dir "/nml_" g "_decl" sfx(rr) ".inc"
      print "! Generated by src/io/tubes_registry_gen.awk: do not edit." > de
      for (i = 1; i <= n; i++) {
        if (G[i] != g || R[i] != rr) continue
        printf "      %s :: %s%s\n", FT[i], N[i], LIST[i] ? "(:)" : "" > de
        printf "      namelist /%s/ %s\n", g, N[i] > de
      }
      close(de)
    }
    for (i = 1; i <= n; i++) {
      if (G[i] != g) continue
      if (LIST[i]) {   # read: every entry (unset ones too); write: the set ones (list_io)
        printf "      call list_io(v%%%s, %s)\n", F[i], N[i] > di
        printf "      if (mode == 'r') v%%%s = %s\n", F[i], N[i] > do_
        continue
      }
      printf "      %s = v%%%s\n", N[i], F[i] > di
      printf "      v%%%s = %s\n", F[i], N[i] > do_
    }
    close(di); close(do_)
    # the group's whole read or write where nothing but copies surrounds it
    printf "      include 'nml_%s_in.inc'\n      if (mode == 'r') then\n", g > rw
    printf "        read (u, nml=%s, iostat=ios, iomsg=iomsg)\n      else\n", g > rw
    printf "        write (u, nml=%s, iostat=ios, iomsg=iomsg)\n      end if\n", g > rw
    printf "      include 'nml_%s_out.inc'\n", g > rw
    close(rw)
  }
}
