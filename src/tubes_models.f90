!> Builds models from the flat parameter vector that crosses the C and Python boundaries:
!> params = [alpha, beta, gamma, xi, h0, g, damping_ratio] (TUBES_NMODEL = 7, include/tubes.h).
module tubes_models
  use tubes_kinds, only: wp
  use tubes_ball, only: ball_t, damped_ball_t, make_ball, ROLL
  use tubes_fourwell, only: fourwell_t
  use tubes_equilibria, only: equilibrium_t, find_equilibria
  use tubes_status, only: TUBES_OK, TUBES_EINPUT
  implicit none
  private
  integer, parameter, public :: NMODEL = 7   !! length of the parameter vector
  public :: conservative_ball, damping_rate, model_ball

contains

  !> The conservative ball on the four-well surface of params(1:6).
  subroutine conservative_ball(params, ball, stat)
    real(wp), intent(in) :: params(NMODEL)
    type(ball_t), intent(out) :: ball
    integer, intent(out) :: stat
    stat = TUBES_OK
    if (params(3) <= 0 .or. params(6) <= 0) then   ! gamma > 0 keeps sqrt real; g > 0
      stat = TUBES_EINPUT
      return
    end if
    call make_ball(ball, fourwell_t(alpha=params(1), beta=params(2), gamma=params(3), &
                                    xi=params(4), h0=params(5)), params(6))
  end subroutine conservative_ball

  !> Damping rate c = 2 zeta omega_1 [1/s], omega_1 the lower small-oscillation frequency at
  !> the lowest well (docs/theory.md, "Damping"). Finds the wells; only call when zeta > 0.
  subroutine damping_rate(ball, zeta, c, stat)
    type(ball_t), intent(in) :: ball
    real(wp), intent(in) :: zeta   !! damping ratio [1]
    real(wp), intent(out) :: c     !! damping rate [1/s]
    integer, intent(out) :: stat
    type(equilibrium_t), allocatable :: eqs(:)
    integer :: k, kbest
    c = 0
    call find_equilibria(ball, 20.0_wp, 41, eqs, stat)
    if (stat /= TUBES_OK) return
    kbest = 0
    do k = 1, size(eqs)
      if (eqs(k)%morse /= 0) cycle
      if (kbest == 0) then
        kbest = k
      else if (eqs(k)%energy < eqs(kbest)%energy) then
        kbest = k
      end if
    end do
    if (kbest == 0) then
      stat = TUBES_EINPUT   ! no well to define the damping ratio against
      return
    end if
    c = 2*zeta*sqrt(ROLL*ball%g*eqs(kbest)%curv(1))
  end subroutine damping_rate

  !> The model a scene integrates: conservative unless params(7) (zeta) > 0.
  subroutine model_ball(params, model, c, stat)
    real(wp), intent(in) :: params(NMODEL)
    class(ball_t), allocatable, intent(out) :: model
    real(wp), intent(out) :: c      !! damping rate used [1/s] (0 if conservative)
    integer, intent(out) :: stat
    type(ball_t) :: ball
    type(damped_ball_t) :: damped
    c = 0
    call conservative_ball(params, ball, stat)
    if (stat /= TUBES_OK) return
    if (params(7) > 0) then
      call damping_rate(ball, params(7), c, stat)
      if (stat /= TUBES_OK) return
      allocate (damped%surf, source=ball%surf)
      damped%g = ball%g
      damped%c = c
      allocate (model, source=damped)
    else
      allocate (model, source=ball)
    end if
  end subroutine model_ball
end module tubes_models
