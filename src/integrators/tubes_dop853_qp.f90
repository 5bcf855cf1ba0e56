!> DOP853 in quad precision (real128) for reference solutions, on a vector field written in
!> real128 (qp_field_t). The step, its error control and the starting step are tubes_dop853's
!> own source compiled in real128 (tubes_dop853_step.inc, tubes_start_step.inc; docs/
!> development.md, "Kind-generic sources"). The coefficients are tubes_dop853_tableau's: its
!> 30-digit decimal strings are real128 literals there (relative rounding <= 1e-29, far below
!> the ~1e-25 the references aim at), rounded for the double-precision stepper. The order
!> conditions are checked in qp in tests/test_reference.f90. No dense output: a reference is the
!> state at the end time. Cost and accuracy: docs/events.md ("Reference solutions").
module tubes_dop853_qp
  use tubes_kinds, only: qp, i8
  use tubes_dop853_tableau, only: qp_tableau_a, qp_tableau_e3, qp_tableau_e5, qp_nodes, NS, NSX, &
                                  DOP853_SAFETY, DOP853_FAC_MIN, DOP853_FAC_MAX
  use tubes_qp_field, only: qp_field_t, field_rk => qp_field_t
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ESTEP, TUBES_EMODEL, TUBES_EMAXSTEPS
  implicit none
  private

  integer, parameter, public :: QP_NS = NS    !! stages of the 8th-order step
  integer, parameter :: rk = qp   ! the kind of the kind-generic sources included below

  public :: qp_field_t
  public :: dop853_qp_solve, qp_tableau_a, qp_tableau_e3, qp_tableau_e5, qp_nodes

contains


  !> Integrate x from t0 to t_end (either direction) with adaptive DOP853 in real128: the
  !> double-precision method's step (dop853_attempt: error control, step-size rule, landing on
  !> t_end) and starting step (start_step), from t0. On failure x is the state at t_reached,
  !> the last accepted step.
  subroutine dop853_qp_solve(f, t0, x, t_end, rtol, atol, stat, t_reached, nsteps, nfev, &
                             nrejected, max_steps)
    class(qp_field_t), intent(in) :: f
    real(qp), intent(in) :: t0                      !! initial time
    real(qp), intent(inout) :: x(:)                 !! state at t0; on return at t_reached
    real(qp), intent(in) :: t_end                   !! final time
    real(qp), intent(in) :: rtol, atol              !! tolerances (> 0)
    integer, intent(out) :: stat                    !! TUBES_OK or a failure code
    real(qp), intent(out), optional :: t_reached    !! t_end, or the last accepted time
    integer(i8), intent(out), optional :: nsteps    !! accepted steps
    integer(i8), intent(out), optional :: nfev      !! right-hand-side evaluations
    integer(i8), intent(out), optional :: nrejected !! rejected steps
    integer(i8), intent(in), optional :: max_steps  !! step budget (default 10^8)
    real(qp) :: a(NSX, NSX), at(NSX, NSX), e3(NS + 1), e5(NS + 1), k(size(x), NS + 1), cq(NSX)
    real(qp) :: t, dir, h, h_next, xnew(size(x))
    integer(i8) :: ns_acc, nf, nrej, budget
    integer :: i, fs
    integer, allocatable :: i3(:), i5(:)
    logical :: last
    t = t0
    ns_acc = 0; nf = 0; nrej = 0
    budget = 100000000_i8
    if (present(max_steps)) budget = max_steps
    stat = TUBES_OK
    if (size(x) /= f%dim() .or. .not. (rtol > 0 .and. atol > 0)) then
      stat = TUBES_EINPUT
      call report()
      return
    end if
    a = qp_tableau_a()
    at = transpose(a)
    cq = qp_nodes()
    e3 = qp_tableau_e3()
    e5 = qp_tableau_e5()
    i3 = pack([(i, i = 1, NS + 1)], e3 /= 0)
    i5 = pack([(i, i = 1, NS + 1)], e5 /= 0)
    dir = sign(1.0_qp, t_end - t0)
    call f%eval(t, x, k(:, 1), fs)
    nf = nf + 1
    if (fs /= 0) then
      stat = TUBES_EMODEL
      call report()
      return
    end if
    if (t_end == t0) then
      call report()
      return
    end if
    call start_step(f, t, x, k(:, 1), dir, rtol, atol, 7, h, nf)
    do while (dir*(t_end - t) > 0)
      if (ns_acc >= budget) then
        stat = TUBES_EMAXSTEPS
        exit
      end if
      call dop853_attempt(f, t, t_end, dir, x, k, at, cq, e3, e5, i3, i5, rtol, atol, .false., &
                          h, last, xnew, h_next, nf, nrej, stat)
      if (stat /= TUBES_OK) exit
      x = xnew
      if (last) then
        t = t_end
      else
        t = t + dir*h
      end if
      k(:, 1) = k(:, NS + 1)   ! FSAL
      ns_acc = ns_acc + 1
      h = h_next
    end do
    call report()

  contains

    subroutine report()
      if (present(t_reached)) t_reached = t
      if (present(nsteps)) nsteps = ns_acc
      if (present(nfev)) nfev = nf
      if (present(nrejected)) nrejected = nrej
    end subroutine report
  end subroutine dop853_qp_solve

  include 'tubes_dop853_step.inc'   ! dop853_attempt and combine in real(qp)
  include 'tubes_start_step.inc'    ! start_step in real(qp)
end module tubes_dop853_qp
