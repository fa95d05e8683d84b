#!/usr/bin/env python3
"""Independent check of docs/collapse.md (no suslov code): on the paper's problem (I = diag(1,
2, 3), Omega_a = [5, 0, 0], Omega_b = phi_par(10), alpha = 1, beta = 0.1, gamma = 1, delta = 0.2,
eta = 1 or 0.01, the spiral Omega_d), an admissible control with |xi| = eps = 1e-3 along the
projected segment Omega_a -> Omega_b in time T: xi = eps * unit(I Om' - (I Om) x Om) of the
path, derivatives by central differences. Suslov's equations I Om' = (I Om) x Om + lam xi,
lam from d/dt <Om, xi> = 0, are integrated with scipy's solve_ivp (rtol 1e-11) from Omega_a;
the cost by the trapezoid rule on 4001 points. Prints J, |Om(T) - Omega_b| and
max |<Om, xi>| / eps. Needs numpy and scipy; takes a few minutes.

Measured 2026-11-26: eta = 0.01, T = 0.157: J = 0.85604 (the extremal: 2.66585);
eta = 1, T = 1.5: J = 9.41701 (the extremal: 15.3948).
"""
import numpy as np
from scipy.integrate import solve_ivp
I=np.array([1.,2.,3.]); oa=np.array([5.,0,0]); E=oa@(I*oa)
def proj(v): return v*np.sqrt(E/(v@(I*v)))
def phi(t): return np.array([10., t*np.cos(t), t*np.sin(t)])
def od(t, bd=10., w=0.01):
    s=0.5*(1+np.tanh((t-bd)/w)); return proj(phi(t))*(1-s)+proj(phi(bd))*s
ob=proj(phi(10.))
def path(t,T):  # projected segment and derivatives by complex-step-free finite differences
    return proj(oa+(ob-oa)*t/T)
def jet(t,T,h=1e-6):
    p=path(t,T); d=(path(t+h,T)-path(t-h,T))/(2*h); return p,d
def xi_of(t,T,eps,h=1e-6):
    def xhat(t):
        p,d=jet(t,T); v=I*d-np.cross(I*p,p); return v/np.linalg.norm(v)
    x=xhat(t); xd=(xhat(t+h)-xhat(t-h))/(2*h); return eps*x, eps*xd
def rhs(t,om,T,eps):
    xi,xid=xi_of(t,T,eps); m=I*om; f=np.cross(m,om)
    lam=-(np.dot(f/I,xi)+np.dot(om,xid))/np.dot(xi,xi/I)
    return (f+lam*xi)/I
def run(alpha,beta,gamma,eta,delta,T,eps):
    sol=solve_ivp(rhs,(0,T),oa,args=(T,eps),rtol=1e-11,atol=1e-12,dense_output=True)
    ts=np.linspace(0,T,4001); J=0
    vals=[]
    for t in ts:
        om=sol.sol(t); xi,xid=xi_of(t,T,eps); omd=rhs(t,om,T,eps)
        C=alpha/4*(xi@xi-1)**2+beta/2*xid@xid+gamma/2*np.sum((om-od(t))**2)+eta/2*omd@omd+delta
        vals.append(C)
    J=np.trapezoid(vals,ts)
    return J, np.linalg.norm(sol.y[:,-1]-ob), max(abs(np.dot(sol.sol(t),xi_of(t,T,eps)[0]))/eps for t in ts)
for eta,T in [(0.01,0.157),(1.0,1.5)]:
    J,err,cons=run(1,0.1,1,eta,0.2,T,1e-3)
    print(f"eta={eta} T={T}: J={J:.5f}  |Om(T)-Om_b|={err:.2e}  max|<Om,xi/eps>|={cons:.1e}")
