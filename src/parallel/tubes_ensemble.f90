!> The ensemble layer (docs/development.md, "Parallel loops"; docs/cluster.md): every parallel
!> loop of tubes runs here. An ensemble's items 1..n (tube seeds, Monte Carlo points, Poincare
!> seeds, synthetic tracks, multiple-shooting segments, flux samples, 3-DOF cut nodes, Python's
!> ensembles) are computed independently of one another. ens_run deals them out over the MPI
!> ranks (tubes_par: item k on rank mod(k - 1, nranks)), over a rank's OpenMP threads in chunks,
!> fails the item that the tests' TUBES_FAULT names, and gathers every item's results to every
!> rank, in index order. Each item is computed by the same code from the same inputs wherever it
!> runs, so the results are the serial run's bit for bit for any number of ranks and threads.
!>
!> A numerics module describes a loop by extending ensemble_t: the loop's inputs as components,
!> `item` computing one item into its column of ens_out_t. An ensemble integrated in the Taylor
!> method's lanes overrides `chunk` (a thread's unit of work) with a run_lanes call. Inputs that
!> come from work every rank repeats are made rank 0's with ens_agree first (so that ranks agree
!> even if their libraries' kernels differ in the last bit). Numerics modules never call MPI,
!> OpenMP's loop constructs or the environment: this module and tubes_par do.
module tubes_ensemble
  use tubes_kinds, only: wp
  use tubes_par, only: par_t, par_here, par_share, par_bcast, par_fault_item
  use tubes_status, only: TUBES_OK, TUBES_EFAULT, TUBES_EINTERRUPT
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_char
  implicit none
  private

  interface
    !> 1 once the caller asked the computation to stop (src/base/tubes_cancel_shim.c)
    integer(c_int) function cancel_requested() bind(C, name='tubes_cancel_requested')
      import :: c_int
    end function cancel_requested
    !> progress lines on stderr (src/base/tubes_progress_shim.c; on in the program only)
    subroutine progress_begin(fault, n) bind(C, name='tubes_progress_begin')
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: fault(*)
      integer(c_int), value :: n
    end subroutine progress_begin
    !> a scene's own progress line, printed at once (the program's scenes; not in a record)
    subroutine progress_line(text, len) bind(C, name='tubes_progress_line')
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: text(*)
      integer(c_int), value :: len
    end subroutine progress_line
    subroutine progress_tick(done, total) bind(C, name='tubes_progress_tick')
      import :: c_long
      integer(c_long), value :: done, total
    end subroutine progress_tick
  end interface

  !> The results of items 1..n, item k's in column k.
  type, public :: ens_out_t
    real(wp), allocatable :: r(:, :)     !! its reals (nr, n)
    integer, allocatable :: i(:, :)      !! its integers (ni, n)
    integer, allocatable :: st(:)        !! its status: TUBES_OK, or < 0 when it failed
  end type ens_out_t

  !> An ensemble: its inputs (the extension's components) and how one item is computed.
  type, abstract, public :: ensemble_t
  contains
    procedure(item_i), deferred :: item
    procedure :: chunk => ens_chunk_items   !! a thread's unit of work: its items one by one
  end type ensemble_t

  abstract interface
    !> Compute item k into out%r(:, k), out%i(:, k) and out%st(k), and nothing else of out
    !> (items run at once on several threads). They come in as 0 and TUBES_OK.
    subroutine item_i(self, k, out)
      import :: ensemble_t, ens_out_t
      class(ensemble_t), intent(in) :: self
      integer, intent(in) :: k
      type(ens_out_t), intent(inout) :: out
    end subroutine item_i
  end interface

  !> Rank 0's copy of a loop's input on every rank (with local = .true.: this rank's own).
  interface ens_agree
    module procedure agree_r0, agree_r1, agree_r2
  end interface ens_agree

  public :: ens_run, ens_chunk_items, ens_agree, ens_reuse_ok, ens_cancelled
  public :: progress_begin, progress_tick   ! the progress lines' C entries (a scene's own loop too)
  public :: progress_line
contains

  !> Compute items 1..n of ens: this rank's share over its threads, then every item's results on
  !> every rank. The loop's fault name (fault) makes item k = par_fault_item(fault) - first + 1
  !> fail with TUBES_EFAULT (tests only), without computing it.
  subroutine ens_run(ens, n, out, nr, ni, fault, first, local, skip, chunk, threads)
    use omp_lib, only: omp_get_max_threads, omp_in_parallel
    class(ensemble_t), intent(inout) :: ens
    integer, intent(in) :: n                    !! number of items
    type(ens_out_t), intent(out) :: out
    integer, intent(in) :: nr                   !! reals per item
    integer, intent(in) :: ni                   !! integers per item
    character(*), intent(in), optional :: fault !! the loop's name for TUBES_FAULT (seed, sample, ...)
    integer, intent(in), optional :: first      !! the number TUBES_FAULT gives item 1 (default 1)
    logical, intent(in), optional :: local      !! this rank alone: the caller dealt out a coarser level
    logical, intent(in), optional :: skip(:)    !! items not computed (known already): 0, TUBES_OK
    integer, intent(in), optional :: chunk      !! items per thread's unit of work (default 1)
    integer, intent(in), optional :: threads    !! OpenMP threads (absent or <= 0: all)
    type(par_t) :: grp
    integer, allocatable :: todo(:)
    logical :: doit(n)
    integer :: k, kf, c, m, nc, nthr
    integer(c_long) :: done, now_done
    logical :: report
    allocate (out%r(nr, n), out%i(ni, n), out%st(n))
    out%r = 0
    out%i = 0
    out%st = TUBES_OK
    grp = par_here(local)
    doit = grp%mine([(k, k = 1, n)])
    if (present(skip)) doit = doit .and. .not. skip
    kf = 0
    if (present(fault)) kf = par_fault_item(fault)
    if (kf > 0 .and. present(first)) kf = kf - first + 1
    if (kf >= 1 .and. kf <= n) then
      if (doit(kf)) out%st(kf) = TUBES_EFAULT
      doit(kf) = .false.
    end if
    todo = pack([(k, k = 1, n)], doit)
    m = 1
    if (present(chunk)) m = max(1, chunk)
    nc = (size(todo) + m - 1)/m
    nthr = omp_get_max_threads()
    if (present(threads)) then
      if (threads > 0) nthr = threads
    end if
    report = .not. omp_in_parallel() .and. nc > 1   ! a nested loop's progress is its caller's
    done = 0
    if (report) then
      if (present(fault)) then
        call progress_begin(fault, len(fault))
      else
        call progress_begin('', 0)
      end if
    end if
    !$omp parallel do schedule(dynamic) default(shared) private(c, now_done) num_threads(nthr)
    do c = 1, nc
      ! Ctrl-C in Python (tubes_cancel_begin): the units left are not computed, their items
      ! TUBES_EINTERRUPT (the caller raises KeyboardInterrupt; no store keeps a failed item)
      if (cancel_requested() /= 0) then
        out%st(todo((c - 1)*m + 1:min(size(todo), c*m))) = TUBES_EINTERRUPT
        cycle
      end if
      call ens%chunk(todo((c - 1)*m + 1:min(size(todo), c*m)), out)
      if (report) then
        !$omp atomic capture
        done = done + (min(size(todo), c*m) - (c - 1)*m)
        now_done = done
        !$omp end atomic
        call progress_tick(now_done, int(size(todo), c_long))
      end if
    end do
    !$omp end parallel do
    call par_share(out%r, grp)
    call par_share(out%i, grp)
    call par_share(out%st, grp)
  end subroutine ens_run

  !> The default unit of work: the items ks one after the other.
  subroutine ens_chunk_items(self, ks, out)
    class(ensemble_t), intent(inout) :: self
    integer, intent(in) :: ks(:)
    type(ens_out_t), intent(inout) :: out
    integer :: j
    do j = 1, size(ks)
      call self%item(ks(j), out)
    end do
  end subroutine ens_chunk_items

  !> Has the caller asked the computation to stop (Ctrl-C in Python: tubes_cancel_begin)? For a
  !> long serial loop outside ens_run (it returns TUBES_EINTERRUPT then).
  logical function ens_cancelled()
    ens_cancelled = cancel_requested() /= 0
  end function ens_cancelled

  !> May a loop take earlier results (a cache) for items instead of computing them? Only on one
  !> rank (the caches of several would have to agree) and without an injected fault for it.
  logical function ens_reuse_ok(fault, local) result(ok)
    character(*), intent(in) :: fault       !! the loop's name for TUBES_FAULT
    logical, intent(in), optional :: local   !! this rank alone
    type(par_t) :: grp
    grp = par_here(local)
    ok = grp%nranks == 1 .and. par_fault_item(fault) == 0
  end function ens_reuse_ok

  subroutine agree_r0(a, local)
    real(wp), intent(inout) :: a
    logical, intent(in), optional :: local   !! this rank alone: nothing to agree on
    call par_bcast(a, par_here(local))
  end subroutine agree_r0

  subroutine agree_r1(a, local)
    real(wp), intent(inout), contiguous :: a(:)
    logical, intent(in), optional :: local
    call par_bcast(a, par_here(local))
  end subroutine agree_r1

  subroutine agree_r2(a, local)
    real(wp), intent(inout), contiguous :: a(:, :)
    logical, intent(in), optional :: local
    call par_bcast(a, par_here(local))
  end subroutine agree_r2
end module tubes_ensemble
