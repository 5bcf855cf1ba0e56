!> The scenes of the core (src/workflow/tubes_scene_*.f90) for the C driver, and their result
!> records read item by item (include/tubes.h, "Scenes and their records"; src/io/tubes_record_write.c
!> walks a record into the output file and onto the console).
module tubes_capi_record
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_char, c_ptr, c_intptr_t, c_long_long, c_null_char
  use tubes_cstrings, only: c_to_f, f_to_c
  use tubes_models, only: MAX_PARAMS, MAX_DOF, LEN_SYSTEM
  use tubes_study, only: seed_stores_t, stores_at
  use tubes_record, only: record_t, record_keep, record_at, record_drop
  use tubes_scene_equilibria, only: scene_equilibria
  implicit none
  private

contains

  !> The equilibria scene (tubes_scene_equilibria): the record's handle (free it with tubes_record_free).
  integer(c_int) function c_scene_equilibria(system, params, lo, hi, n_grid, box, want, asked, label, dissip, &
                                             stores) result(h) bind(C, name='tubes_equilibria_scene')
    character(kind=c_char), intent(in) :: system(LEN_SYSTEM), want(8), label(64), dissip(128)
    real(c_double), intent(in) :: params(MAX_PARAMS), lo(MAX_DOF), hi(MAX_DOF)
    integer(c_int), value :: n_grid, asked
    real(c_double), value :: box
    type(c_ptr), value :: stores
    type(record_t), allocatable :: rec
    type(seed_stores_t), pointer :: kept
    allocate (rec)
    kept => stores_at(transfer(stores, 0_c_intptr_t))
    call scene_equilibria(trim(c_to_f(system)), params, lo, hi, n_grid, box, trim(c_to_f(want)), asked /= 0, &
                          trim(c_to_f(label)), trim(c_to_f(dissip)), kept, rec)
    h = record_keep(rec)
  end function c_scene_equilibria

  !> The record's exit code (the worst verdict's; 0: none), or -1 for no record.
  integer(c_int) function c_record_code(h) result(code) bind(C, name='tubes_record_code')
    integer(c_int), value :: h
    type(record_t), pointer :: r
    r => record_at(h)
    code = -1
    if (associated(r)) code = r%code
  end function c_record_code

  !> Its numbers of items and of console lines.
  subroutine c_record_sizes(h, n_items, n_lines) bind(C, name='tubes_record_sizes')
    integer(c_int), value :: h
    integer(c_int), intent(out) :: n_items, n_lines
    type(record_t), pointer :: r
    r => record_at(h)
    n_items = 0
    n_lines = 0
    if (.not. associated(r)) return
    n_items = r%n_items
    n_lines = r%n_lines
  end subroutine c_record_sizes

  !> Line j (1-based) of its console: stream 1 stdout, 2 stderr; its text into buf (len bytes,
  !> NUL-terminated); its length (to ask again with a larger buf), or -1 for no such line.
  integer(c_int) function c_record_line(h, j, stream, buf, len) result(n) bind(C, name='tubes_record_line')
    integer(c_int), value :: h, j, len
    integer(c_int), intent(out) :: stream
    character(kind=c_char), intent(out) :: buf(len)
    type(record_t), pointer :: r
    integer :: k
    r => record_at(h)
    n = -1
    stream = 0
    if (len > 0) buf(1) = c_null_char
    if (.not. associated(r)) return
    if (j < 1 .or. j > r%n_lines) return
    stream = r%lines(j)%stream
    n = len_trim(r%lines(j)%text)
    do k = 1, min(n, len - 1)
      buf(k) = r%lines(j)%text(k:k)
    end do
    if (len > 0) buf(min(n, len - 1) + 1) = c_null_char
  end function c_record_line

  !> Item k (1-based): its kind (tubes_record REC_*), group path, name, units (NUL-terminated),
  !> rank and dims (C order); the number of its values (strings: their count, and in slen the
  !> longest's length). -1: no such item.
  integer(c_int) function c_record_item(h, k, kind, group, name, units, rank, dims, slen) result(n) &
      bind(C, name='tubes_record_item')
    integer(c_int), value :: h, k
    integer(c_int), intent(out) :: kind, rank, slen
    character(kind=c_char), intent(out) :: group(256), name(64), units(32)
    integer(c_long_long), intent(out) :: dims(4)
    type(record_t), pointer :: r
    r => record_at(h)
    n = -1
    kind = 0
    rank = 0
    slen = 0
    dims = 0
    group(1) = c_null_char
    name(1) = c_null_char
    units(1) = c_null_char
    if (.not. associated(r)) return
    if (k < 1 .or. k > r%n_items) return
    associate (it => r%items(k))
      kind = it%kind
      call f_to_c(it%group, group)
      call f_to_c(it%name, name)
      call f_to_c(it%units, units)
      rank = it%rank
      dims = it%dims
      if (allocated(it%r)) n = size(it%r)
      if (allocated(it%i)) n = size(it%i)
      if (allocated(it%s)) then
        n = size(it%s)
        slen = len(it%s)
      end if
    end associate
  end function c_record_item

  !> Item k's real values (n of them, C order).
  subroutine c_record_reals(h, k, n, v) bind(C, name='tubes_record_reals')
    integer(c_int), value :: h, k, n
    real(c_double), intent(out) :: v(n)
    type(record_t), pointer :: r
    r => record_at(h)
    v = 0
    if (.not. associated(r)) return
    if (k < 1 .or. k > r%n_items) return
    if (.not. allocated(r%items(k)%r)) return
    v = r%items(k)%r(1:n)
  end subroutine c_record_reals

  !> Item k's integer values (n of them, C order).
  subroutine c_record_ints(h, k, n, v) bind(C, name='tubes_record_ints')
    integer(c_int), value :: h, k, n
    integer(c_int), intent(out) :: v(n)
    type(record_t), pointer :: r
    r => record_at(h)
    v = 0
    if (.not. associated(r)) return
    if (k < 1 .or. k > r%n_items) return
    if (.not. allocated(r%items(k)%i)) return
    v = r%items(k)%i(1:n)
  end subroutine c_record_ints

  !> String j (1-based) of item k, trailing blanks dropped, into buf (len bytes, NUL-terminated).
  subroutine c_record_string(h, k, j, buf, len) bind(C, name='tubes_record_string')
    integer(c_int), value :: h, k, j, len
    character(kind=c_char), intent(out) :: buf(len)
    type(record_t), pointer :: r
    r => record_at(h)
    if (len > 0) buf(1) = c_null_char
    if (.not. associated(r)) return
    if (k < 1 .or. k > r%n_items) return
    if (.not. allocated(r%items(k)%s)) return
    if (j < 1 .or. j > size(r%items(k)%s)) return
    call f_to_c(r%items(k)%s(j), buf)
  end subroutine c_record_string

  !> Forget the record.
  subroutine c_record_free(h) bind(C, name='tubes_record_free')
    integer(c_int), value :: h
    call record_drop(h)
  end subroutine c_record_free
end module tubes_capi_record
